#!/usr/bin/env python3
"""Writes the fuzz seeds in fuzz/corpus/ (run from anywhere): copies of repository files,
hand-made datagrams and requests (layouts of include/ips/output/wire.h), small JPEGs of a real photo.
The model_file seeds are `ips fit` outputs, made by
  for m in rt pr rt+pr ann ki plane auto; do
    ips fit --data calib_data/ou2023/train40.csv --camera red --method $m --out fuzz/corpus/model_file/red_${m/+/_}.json
  done"""
import hashlib, hmac, os, shutil, struct, subprocess, sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
C = os.path.join(ROOT, "fuzz", "corpus")


def put(target, name, data):
    os.makedirs(os.path.join(C, target), exist_ok=True)
    with open(os.path.join(C, target, name), "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)


def copy(target, *paths):
    for p in paths:
        put(target, os.path.basename(p), open(os.path.join(ROOT, p), "rb").read())


def datagram(markers, velocity=False, part=0, parts=1, extra=0, bodies=None, body_extra=0, body_velocity=True):
    """bodies (a list of (name, ids)) makes it version 2; body_velocity False: the first
    senders' 100-byte body records (no velocity fields)."""
    rs = (48 if velocity else 36) + extra
    h = b"IPSD" + struct.pack("<HHIHHBBHIqqq", 1 if bodies is None else 2, 1 if velocity else 0, 7, len(markers), rs,
                              part, parts, 0, 42, 1700000000000000000, 123456789, 1700000000001000000)
    body = b""
    for i, (mid, x, y) in enumerate(markers):
        r = struct.pack("<IIffffffi", mid, 0b101, x, y, 0.1, 1.57, 2500.0, 0.004, -1200 * i)
        if velocity:
            r += struct.pack("<fff", 0.5, -0.25, 0.0)
        body += r + b"\0" * extra
    if bodies is not None:
        body += struct.pack("<HH", len(bodies), (116 if body_velocity else 100) + body_extra)
        for i, (name, ids) in enumerate(bodies):
            listed = (list(ids[:4]) + [0, 0, 0, 0])[:4]
            flags = 7 if body_velocity and i % 2 == 0 else 1  # yaw (+ velocity, yaw rate)
            body += struct.pack("<32sIffffffffffiHH4I", name.encode(), 0b11, 1.0 + i, -0.5, 0.0, 0.3,
                                0.989, 0.0, 0.0, 0.149, 1800.0, 0.003, -500 * i, flags, len(ids), *listed)
            if body_velocity:
                body += struct.pack("<ffff", 0.4, -0.1, 0.0, 0.25) if flags == 7 else b"\0" * 16
            body += b"\0" * body_extra
    return h + body


def tj_crop(jpeg, w, h, gray):
    """`jpeg` decoded at 1/8 scale, its middle w x h as raw grey or RGB bytes."""
    import ctypes
    tj = ctypes.CDLL("libturbojpeg.so.0")
    tj.tjInitDecompress.restype = tj.tjInitCompress.restype = ctypes.c_void_p
    d = ctypes.c_void_p(tj.tjInitDecompress())
    W, H, ss, cs = (ctypes.c_int() for _ in range(4))
    assert tj.tjDecompressHeader3(d, jpeg, ctypes.c_ulong(len(jpeg)), ctypes.byref(W), ctypes.byref(H),
                                  ctypes.byref(ss), ctypes.byref(cs)) == 0
    sw, sh = (W.value + 7) // 8, (H.value + 7) // 8
    ch = 1 if gray else 3
    full = ctypes.create_string_buffer(sw * sh * ch)
    assert tj.tjDecompress2(d, jpeg, ctypes.c_ulong(len(jpeg)), full, sw, sw * ch, sh, 6 if gray else 0, 0) == 0
    x0, y0 = (sw - w) // 2, (sh - h) // 2  # the middle, where the picture is
    return b"".join(full.raw[((y0 + y) * sw + x0) * ch:((y0 + y) * sw + x0 + w) * ch] for y in range(h))


def tj_small(jpeg, w, h, gray, samp, progressive, quality):
    """`jpeg` decoded at 1/8 scale, its middle w x h re-encoded (TJPF_GRAY=6 / TJPF_RGB=0)."""
    import ctypes
    tj = ctypes.CDLL("libturbojpeg.so.0")
    tj.tjInitCompress.restype = ctypes.c_void_p
    crop = tj_crop(jpeg, w, h, gray)
    ch = 1 if gray else 3
    c = ctypes.c_void_p(tj.tjInitCompress())
    out, size = ctypes.c_void_p(), ctypes.c_ulong()
    assert tj.tjCompress2(c, crop, w, w * ch, h, 6 if gray else 0, ctypes.byref(out), ctypes.byref(size), samp,
                          quality, 16384 if progressive else 0) == 0
    data = ctypes.string_at(out, size.value)
    tj.tjFree(out)
    return data


def main():
    copy("config", "config/ipsd.yaml", "config/demo.yaml")
    put("config", "ranging.yaml",
        "cameras:\n  - {name: red, source: synthetic, scene: scene.yaml}\nmodel_file: model.json\n"
        "ranging:\n  port: 5800\n  allow: [10.0.0.0/8, 192.168.1.7]\n  psk: k\n  method: median4\n  z_range: [0, 2]\n"
        "  anchors:\n    - {id: 1, x: 0, y: 0, z: 2.5, bias: 0.02, scale: 1.001, sigma: 0.04}\n"
        "    - {id: 2, x: 4, y: 0, z: 1}\n    - {id: 3, x: 4, y: 3, z: 2.5}\n    - {id: 4, x: 0, y: 3, z: 1}\n"
        "  tags:\n    - {id: 7, marker: 20}\n")
    copy("scene", "config/scenes/ou2023.yaml", "config/scenes/calib_lenses.yaml", "config/scenes/survey_lab.yaml")
    put("scene", "ranging.yaml",
        "markers:\n  - {id: 1, height: 0.1, trajectory: {type: circle, center: [3, 2], radius: 0.45, speed: 0.2}}\n"
        "  - {id: 2, x: 1, y: 1}\nanchors:\n  - {id: 1, position: [0, 0, 2.5], sigma: 0.05, bias: 0.02}\n"
        "  - {id: 2, position: [6, 0, 2], max_range: 8, dropout: 0.1}\n"
        "nlos_zones:\n  - {min: [4, 3, 0], max: [5, 4, 2.5], bias: 0.5}\n"
        "tags:\n  - {id: 7, marker: 1, height: 0.2, range_tags: true}\n  - {id: 8, marker: 2}\n")
    # Lamps are read last: a scene of anchors alone (no camera to load) reaches them.
    put("scene", "lamps.yaml",
        "anchors:\n  - {id: 1, position: [0, 0, 2.5]}\nlamps:\n  - {x: 1, y: 1, height: 2.8, radius: 0.2}\n"
        "  - {x: 2, y: 1, height: 2.8, size: [0.6, 0.3], yaw_deg: 20, brightness: 250, glare: 0.4, glare_width: 0.3}\n")
    copy("intrinsics", "calib_data/ou2023/intrinsics_red.yaml", "config/scenes/lenses/pinhole_wide.yaml")
    put("intrinsics", "opencv_fisheye.yaml",
        "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n"
        "   dt: d\n   data: [ 300., 0., 320., 0., 300., 240., 0., 0., 1. ]\n"
        "distortion_coefficients: !!opencv-matrix\n   rows: 4\n   cols: 1\n   dt: d\n   data: [ 0.01, -0.002, 0.0003, 0. ]\n"
        "distortion_model: fisheye\n")
    put("intrinsics", "opencv_pinhole.xml",
        "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width>640</image_width>\n<image_height>480</image_height>\n"
        "<camera_matrix type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols><dt>d</dt>\n"
        "<data>500. 0. 320. 0. 500. 240. 0. 0. 1.</data></camera_matrix>\n"
        "<distortion_coefficients type_id=\"opencv-matrix\"><rows>5</rows><cols>1</cols><dt>d</dt>\n"
        "<data>0.1 -0.05 0. 0. 0.01</data></distortion_coefficients>\n</opencv_storage>\n")
    put("intrinsics", "opencv.json",
        "{\n  \"image_width\": 640, \"image_height\": 480,\n  \"camera_matrix\": {\"type_id\": \"opencv-matrix\", \"rows\": 3, "
        "\"cols\": 3, \"dt\": \"d\", \"data\": [300.0, 0.0, 320.0, 0.0, 300.0, 240.0, 0.0, 0.0, 1.0]},\n"
        "  \"distortion_coefficients\": {\"type_id\": \"opencv-matrix\", \"rows\": 4, \"cols\": 1, \"dt\": \"d\", "
        "\"data\": [0.01, -0.002, 0.0003, 0.0]}\n}\n")
    csv = open(os.path.join(ROOT, "calib_data/ou2023/train40.csv")).read().splitlines()
    put("calib_csv", "train_head.csv", "\n".join(csv[:12]) + "\n")
    put("calib_csv", "points.csv", "xw,yw,zw,label\n0.5,1.0,0.12,a\n-1.25,2.0,0.12,b\n3,0,0\n")
    put("calib_csv", "entry_lines.txt", "1.0 2.0 0.12\n0.5 0.5\nu\nq\n-3 4.5 0\n")
    put("calib_csv", "ranges.csv", "fix,reference,range,sigma,ref_x,ref_y,ref_z,ref_sigma\n"
        "1,a,2.1,0.05,,,,\n1,b,4.3,,,,,\n1,c,4.4,0.05,,,,\n1,1,2.9,0.05,,,,\n"
        "2,a,1,0.1,,,,\n2,robot,1.5,0.05,3,2,0.3,0.02\n")
    put("datagram", "binary_2.bin", datagram([(7, 1.5, -2.25), (12, 0.0, 3.0)]))
    put("datagram", "binary_velocity.bin", datagram([(3, 0.25, 0.5)], velocity=True, part=1, parts=2))
    put("datagram", "binary_future_record.bin", datagram([(9, 1.0, 1.0)], extra=8))
    put("datagram", "binary_empty.bin", datagram([]))
    put("datagram", "binary_v2_bodies.bin", datagram([(7, 1.5, -2.25)], bodies=[("cube", [5]), ("two", [21, 22])]))
    put("datagram", "binary_v2_first_senders.bin", datagram([], bodies=[("cube", [5])], body_velocity=False))
    put("datagram", "binary_v2_future_body.bin", datagram([], bodies=[("robot_with_a_long_name_31_bytes", [1, 2, 3, 4, 5])],
                                                            body_extra=8))
    put("datagram", "json_v2.json",
        '{"type":"ips.positions","version":2,"seq":3,"update":2,"part":0,"parts":1,"t_capture_real_ns":1,'
        '"t_capture_mono_ns":2,"t_publish_real_ns":3,"velocity":false,"markers":[],"bodies":[{"name":"cube",'
        '"cameras":3,"x":1.0,"y":2.0,"z":0.0,"yaw":0.5,"qw":0.968912,"qx":0.0,"qy":0.0,"qz":0.247404,'
        '"quality":1800.0,"spread":0.002,"dt_us":0,"has_yaw":true,"id_count":1,"ids":[5],"vx":0.4,"vy":-0.1,'
        '"vz":0.0,"yaw_rate":0.25}]}\n')
    put("datagram", "json_2.json",
        '{"type":"ips.positions","version":1,"seq":7,"update":42,"part":0,"parts":1,'
        '"t_capture_real_ns":1700000000000000000,"t_capture_mono_ns":123456789,"t_publish_real_ns":1700000000001000000,'
        '"velocity":true,"markers":[{"id":7,"cameras":5,"x":1.5,"y":-2.25,"z":0.1,"yaw":1.57,"quality":2500,'
        '"spread":0.004,"dt_us":0,"vx":0.5,"vy":-0.25,"vz":0}]}\n')
    cookie = bytes(range(16))
    def req(op=1, fmt=0, all_=True, lease=30, ids=(), psk=b""):
        b = b"IPSQ" + bytes([1, op, fmt, 1 if all_ else 0]) + struct.pack("<HH", lease, len(ids)) + cookie
        b += b"".join(struct.pack("<I", i) for i in ids)
        if psk:
            b += hmac.new(psk, b, hashlib.sha256).digest()
        return b
    put("subscription", "subscribe_all.bin", req())
    put("subscription", "subscribe_ids_json.bin", req(fmt=1, all_=False, ids=(3, 7, 1000)))
    put("subscription", "unsubscribe_psk.bin", req(op=2, lease=0, psk=b"lab secret"))
    put("subscription", "subscribe_ids_psk.bin", req(all_=False, ids=(5,), psk=b"lab secret"))
    put("subscription", "reply_challenge.bin", b"IPSA" + bytes([1, 1, 0, 0]) + struct.pack("<HH", 0, 0) + cookie)
    put("subscription", "subnet.txt", "192.168.1.0/24")
    def firing(tag=7, n=1, t=1800000000000000000, refs=((1, 2.5, 0.05), (2, 3.0, 0.0)), odo=None, psk=b""):
        b = b"IPSR" + struct.pack("<BBHIIqHHffI", 1, 1 if odo else 0, len(refs), tag, n, t, 12, 0, *(odo or (0.0, 0.0)), 0)
        b += b"".join(struct.pack("<Iff", r, d, s) for r, d, s in refs)
        if psk:
            b += hmac.new(psk, b, hashlib.sha256).digest()
        return b
    put("range_datagram", "two_anchors.bin", firing())
    put("range_datagram", "mobile_reference_odometry.bin",
        firing(n=2, refs=((1, 2.5, 0.05), (2 | 0x80000000, 1.2, 0.1), (9, 4.0, 0.05)), odo=(0.3, 0.02)))
    put("range_datagram", "no_time_psk.bin", firing(tag=2, n=5, t=0, psk=b"lab secret"))
    for i, line in enumerate(["GET /", "GET /status.json", "GET /events", "GET /assets/app.js",
                              "GET /camera/red.jpg", "GET /camera/white.json", "POST /", "GET /../etc/passwd",
                              "HEAD /status.json"]):
        put("web_request", "request_%d.txt" % i, line)
    put("det_session", "session_two_cameras.txt",
        "ips-record 1\n# comment\nconfig /etc/ipsd/ipsd.yaml\nfingerprint 0123456789abcdef\ndictionary DICT_4X4_100\n"
        "seconds 12.5\ncamera red a.det\ncamera white b.det\n\0"
        "# t_ns id x0 y0 x1 y1 x2 y2 x3 y3\n0 7 100.0 100.0 140.0 100.0 140.0 140.0 100.0 140.0\n"
        "33333333 7 100.5 100.0 140.5 100.0 140.5 140.0 100.5 140.0\n66666666 12 10 10 20 10 20 20 10 20")
    ceiling = ('{"format": "ips-ceiling-map", "version": 1, "dictionary": "DICT_4X4_100", "markers": ['
               '{"id": 0, "x": 1.0, "y": 0.9, "z": 2.8, "yaw": -3.14, "length": 0.25},'
               '{"id": 1, "x": 2.2, "y": 0.9, "z": 2.8, "yaw": -2.5, "length": 0.25, "sigma": [0.001, 0.001, 0.002, 0.01]},'
               '{"id": 6, "x": 1.0, "y": 2.3, "z": 2.8, "yaw": 0.7, "length": 0.25}]}')
    put("ceiling_map", "three_markers.json", ceiling)
    put("ceiling_map", "with_robot_yaml.txt", ceiling + "\0camera:\n  intrinsics: up.yaml\n  mount: {offset: [0.1, 0, 0.25], "
        "yaw_deg: 90}\nlocalise: {pixel_sigma: 0.5, outlier_px: 3, tilt_sigma_deg: 1}\n")
    put("ceiling_map", "one_marker.json",
        '{"format": "ips-ceiling-map", "version": 1, "markers": [{"id": 5, "x": 0, "y": 0, "z": 3, "yaw": 0, "length": 0.2}]}')
    # A number beyond a double is nlohmann::json's out_of_range, not its parse_error (a crash once).
    put("ceiling_map", "number_overflow.json", ceiling.replace('"yaw": -2.5', '"yaw": -1e3081'))
    put("det_session", "det_only.txt", "0 3 1 2 3 4 5 6 7 8\n1000 3 1.5 2 3 4 5 6 7 8\n")
    # Small JPEGs of a real photograph in the forms cameras and encoders produce (libturbojpeg
    # through ctypes: no image tool needed).
    photo = open(os.path.join(ROOT, "tests/data/real_photos/ubq_ceiling_fisheye.jpg"), "rb").read()
    for name, (w, h, gray, samp, progressive, quality) in {
            "gray_64x48.jpg": (64, 48, True, 3, False, 90),
            "color420_80x60.jpg": (80, 60, False, 2, False, 85),
            "color422_progressive_48x36.jpg": (48, 36, False, 1, True, 75),
            "color444_32x32.jpg": (32, 32, False, 0, False, 95),
            "odd_33x17.jpg": (33, 17, True, 3, True, 40)}.items():
        put("jpeg", name, tj_small(photo, w, h, gray, samp, progressive, quality))
    # With restart markers, as some cameras send them (region decodes cut rows out at them):
    # libjpeg-turbo's cjpeg (package libjpeg-turbo-progs), since TurboJPEG 2 cannot write them.
    for name, (w, h, gray, restart) in {
            "color420_restart_rows_96x48.jpg": (96, 48, False, "1"),
            "color420_restart_2rows_50x41.jpg": (50, 41, False, "2"),
            "gray_restart_3mcus_64x48.jpg": (64, 48, True, "3B")}.items():
        pnm = (b"P5" if gray else b"P6") + b" %d %d 255\n" % (w, h) + tj_crop(photo, w, h, gray)
        put("jpeg", name, subprocess.run(["cjpeg", "-quality", "85", "-dct", "fast", "-restart", restart], input=pnm,
                                         stdout=subprocess.PIPE, check=True).stdout)

if __name__ == "__main__":
    main()
