#!/usr/bin/env python3
"""Minimal client of the ipsd position stream (Python standard library only).

Decodes the binary form (layout: include/ips/wire.h, README "daemon") and the JSON-lines
form, and prints one line per marker. Use it as a starting point for a robot's own code:

    python3 tools/ipsd_client.py --port 5005              # unicast/broadcast
    python3 tools/ipsd_client.py --group 239.255.42.1 --port 5006
    python3 tools/ipsd_client.py --port 5005 --count 10   # stop after 10 datagrams
"""
import argparse
import json
import math
import socket
import struct
import sys
import time

MAGIC = b"IPSD"
VERSION = 1
FLAG_VELOCITY = 0x0001
HEADER = struct.Struct("<4sHHIHHBBHIqqq")  # 48 bytes, little-endian
RECORD = struct.Struct("<IIffffffi")        # 36 bytes
VELOCITY = struct.Struct("<fff")            # +12 bytes when FLAG_VELOCITY


class Malformed(ValueError):
    pass


def decode(data: bytes) -> dict:
    """One datagram -> dict with the header fields and a list of marker dicts."""
    if data[:1] == b"{":
        try:
            d = json.loads(data)
        except ValueError as e:
            raise Malformed(f"not valid JSON: {e}") from None
        if not isinstance(d, dict) or d.get("type") != "ips.positions":
            raise Malformed("JSON 'type' is not ips.positions")
        return d
    if len(data) < HEADER.size:
        raise Malformed(f"{len(data)} bytes, shorter than a header")
    (magic, version, flags, seq, count, record_size, part, parts, _reserved, update,
     t_real, t_mono, t_pub) = HEADER.unpack_from(data)
    if magic != MAGIC:
        raise Malformed("bad magic")
    if version != VERSION:
        raise Malformed(f"unsupported protocol version {version}")
    velocity = bool(flags & FLAG_VELOCITY)
    if record_size < RECORD.size + (VELOCITY.size if velocity else 0):
        raise Malformed(f"record_size {record_size} too small")
    if len(data) != HEADER.size + count * record_size:
        raise Malformed("length does not match marker_count * record_size")
    if parts == 0 or part >= parts:
        raise Malformed(f"part {part} of {parts}")
    markers = []
    for i in range(count):
        off = HEADER.size + i * record_size  # step by record_size: newer fields are skipped
        mid, mask, x, y, z, yaw, quality, spread, dt_us = RECORD.unpack_from(data, off)
        m = {"id": mid, "cameras": mask, "x": x, "y": y, "z": z, "yaw": yaw,
             "quality": quality, "spread": spread, "dt_us": dt_us}
        if velocity:
            m["vx"], m["vy"], m["vz"] = VELOCITY.unpack_from(data, off + RECORD.size)
        if not all(math.isfinite(m[k]) for k in ("x", "y", "z", "yaw")):
            raise Malformed("non-finite position")
        markers.append(m)
    return {"type": "ips.positions", "version": version, "seq": seq, "update": update,
            "part": part, "parts": parts, "t_capture_real_ns": t_real,
            "t_capture_mono_ns": t_mono, "t_publish_real_ns": t_pub,
            "velocity": velocity, "markers": markers}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bind", default="0.0.0.0", help="local address to receive on")
    ap.add_argument("--port", type=int, default=5005)
    ap.add_argument("--group", help="multicast group to join")
    ap.add_argument("--count", type=int, default=0, help="stop after N valid datagrams")
    args = ap.parse_args()

    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind(("0.0.0.0" if args.group else args.bind, args.port))
    if args.group:
        mreq = struct.pack("4s4s", socket.inet_aton(args.group), socket.inet_aton("0.0.0.0"))
        sock.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, mreq)

    valid = malformed = 0
    try:
        while args.count == 0 or valid < args.count:
            data, _ = sock.recvfrom(65536)
            try:
                d = decode(data)
            except Malformed as e:
                malformed += 1
                print(f"warning: malformed datagram: {e}", file=sys.stderr)
                continue
            valid += 1
            age_ms = (time.time_ns() - d["t_capture_real_ns"]) / 1e6
            for m in d["markers"]:
                line = (f"seq {d['seq']:6d}  id {m['id']:3d}  x {m['x']:7.3f}  y {m['y']:7.3f}  "
                        f"z {m['z']:6.3f} m  yaw {math.degrees(m['yaw']):7.1f} deg  "
                        f"cams 0x{m['cameras']:02x}  age {age_ms:6.1f} ms")
                if d["velocity"]:
                    line += f"  v ({m['vx']:.2f}, {m['vy']:.2f}) m/s"
                print(line, flush=True)
    except KeyboardInterrupt:
        pass
    print(f"{valid} datagrams, {malformed} malformed", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
