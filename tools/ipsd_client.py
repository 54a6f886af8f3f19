#!/usr/bin/env python3
"""Minimal client of the ipsd position stream (Python standard library only).

Decodes the binary form (layout: include/ips/output/wire.h, docs/stream.md) and the JSON-lines
form, and prints one line per marker (and per rigid body: version 2). Use it as a starting point for a robot's own code:

    python3 tools/ipsd_client.py --port 5005              # unicast/broadcast
    python3 tools/ipsd_client.py --group 239.255.42.1 --port 5006
    python3 tools/ipsd_client.py --port 5005 --count 10   # stop after 10 datagrams
    python3 tools/ipsd_client.py --subscribe 192.168.1.10:5010 --ids 3,7   # unicast subscription
    python3 tools/ipsd_client.py --subscribe 192.168.1.10:5010 --psk "lab key"

--subscribe asks a daemon's `subscriptions` output for a unicast stream to this client's own
address (request, cookie echo, renewal at a third of the lease, unsubscribe at the end; the
layout is in include/ips/output/wire.h, "Unicast subscriptions").
"""
import argparse
import hashlib
import hmac
import json
import math
import socket
import struct
import sys
import time

MAGIC = b"IPSD"
VERSIONS = (1, 2)  # 2 = with rigid bodies (a daemon with `bodies:` configured)
FLAG_VELOCITY = 0x0001
FLAG_SOURCES = 0x0002                       # records name what placed them (ipsd with ranging:)
SOURCE_NAMES = ("camera", "ranges")         # sources bit i -> name; later bits are later sources
MARKER_HAS_YAW = 0x0001
HEADER = struct.Struct("<4sHHIHHBBHIqqq")  # 48 bytes, little-endian
RECORD = struct.Struct("<IIffffffi")        # 36 bytes
VELOCITY = struct.Struct("<fff")            # +12 bytes when FLAG_VELOCITY (always there with FLAG_SOURCES)
SOURCES = struct.Struct("<HH")              # bytes 48-51 with FLAG_SOURCES: sources, marker_flags
BODY_SECTION = struct.Struct("<HH")         # version 2: body_count, body_record_size
BODY = struct.Struct("<32sIffffffffffiHH4I")  # 100 bytes: every body record has these
BODY_VELOCITY = struct.Struct("<ffff")      # bytes 100-115 (records of >= 116 bytes): vx vy vz yaw_rate
BODY_HAS_YAW = 0x0001
BODY_HAS_VELOCITY = 0x0002
BODY_HAS_YAW_RATE = 0x0004


SUB_REQUEST = struct.Struct("<4sBBBBHH16s")  # 28 bytes, then ids (u32 each), then the HMAC
SUB_REPLY = struct.Struct("<4sBBHHH16s")      # 28 bytes
SUB_CHALLENGE, SUB_ACCEPTED, SUB_REFUSED_FULL, SUB_UNSUBSCRIBED = 1, 2, 3, 4


def sub_request(ids, fmt, lease_s, cookie, psk, unsubscribe=False) -> bytes:
    """A subscription request (include/ips/output/wire.h): op 1 subscribe/renew, 2 unsubscribe."""
    body = SUB_REQUEST.pack(b"IPSQ", 1, 2 if unsubscribe else 1, 1 if fmt == "json" else 0,
                            0 if ids else 1, lease_s, len(ids), cookie)
    body += b"".join(struct.pack("<I", i) for i in ids)
    if psk:
        body += hmac.new(psk.encode(), body, hashlib.sha256).digest()
    return body


def sub_reply(data: bytes):
    """(status, lease_s, cookie) of a daemon reply, or None for anything else (stream data)."""
    if len(data) != SUB_REPLY.size or data[:4] != b"IPSA":
        return None
    _magic, version, status, _r0, lease, _r1, cookie = SUB_REPLY.unpack(data)
    return (status, lease, cookie) if version == 1 else None


class Subscription:
    """The robot's side of the exchange: call due() often, reply() on every datagram."""

    def __init__(self, sock, daemon, ids, fmt, lease_s, psk):
        self.sock, self.daemon, self.ids, self.fmt = sock, daemon, ids, fmt
        self.lease_s, self.psk = lease_s, psk
        self.cookie = bytes(16)
        self.next_send = 0.0
        self.subscribed = False

    def due(self):
        now = time.monotonic()
        if now >= self.next_send:
            self.next_send = now + 1.0  # resend if nothing answers
            self.sock.sendto(sub_request(self.ids, self.fmt, self.lease_s, self.cookie, self.psk), self.daemon)

    def reply(self, data) -> bool:
        r = sub_reply(data)
        if r is None:
            return False
        status, lease, cookie = r
        if status == SUB_CHALLENGE:
            self.cookie, self.next_send = cookie, 0.0  # echo it at once
        elif status == SUB_ACCEPTED:
            if not self.subscribed:
                print(f"subscribed (lease {lease} s)", file=sys.stderr)
            self.cookie, self.subscribed = cookie, True
            self.next_send = time.monotonic() + max(0.5, lease / 3)
        elif status == SUB_REFUSED_FULL:
            print("warning: the daemon has max_subscribers; retrying in 5 s", file=sys.stderr)
            self.next_send = time.monotonic() + 5.0
        return True

    def close(self):
        if self.subscribed:
            self.sock.sendto(sub_request(self.ids, self.fmt, self.lease_s, self.cookie, self.psk, True), self.daemon)


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
    if version not in VERSIONS:
        raise Malformed(f"ipsd stream version {version}: this client reads versions 1 and 2; update it")
    velocity = bool(flags & FLAG_VELOCITY)
    sources = bool(flags & FLAG_SOURCES)
    if record_size < RECORD.size + (VELOCITY.size + SOURCES.size if sources else VELOCITY.size if velocity else 0):
        raise Malformed(f"record_size {record_size} too small")
    end = HEADER.size + count * record_size
    bodies = []
    if version == 1 and len(data) != end:
        raise Malformed("length does not match marker_count * record_size")
    if version == 2:
        if len(data) < end + BODY_SECTION.size:
            raise Malformed("too short for the body section")
        body_count, body_size = BODY_SECTION.unpack_from(data, end)
        if body_size < BODY.size:
            raise Malformed(f"body_record_size {body_size} too small")
        if len(data) != end + BODY_SECTION.size + body_count * body_size:
            raise Malformed("length does not match the records and the body section")
        for i in range(body_count):
            off = end + BODY_SECTION.size + i * body_size  # step by body_record_size
            (name, mask, x, y, z, yaw, qw, qx, qy, qz, quality, spread, dt_us, bflags, id_count,
             *ids) = BODY.unpack_from(data, off)
            b = {"name": name.split(b"\0", 1)[0].decode("utf-8", "replace"), "cameras": mask,
                 "x": x, "y": y, "z": z, "yaw": yaw, "qw": qw, "qx": qx, "qy": qy, "qz": qz,
                 "quality": quality, "spread": spread, "dt_us": dt_us,
                 "has_yaw": bool(bflags & BODY_HAS_YAW), "id_count": id_count, "ids": ids[:min(id_count, 4)]}
            if body_size >= BODY.size + BODY_VELOCITY.size:  # older senders: 100 bytes, no velocity
                vx, vy, vz, yaw_rate = BODY_VELOCITY.unpack_from(data, off + BODY.size)
                if bflags & BODY_HAS_VELOCITY:
                    b["vx"], b["vy"], b["vz"] = vx, vy, vz
                if bflags & BODY_HAS_YAW_RATE:
                    b["yaw_rate"] = yaw_rate
            if sources and body_size >= BODY.size + BODY_VELOCITY.size + 4:  # 120 bytes: sources at 116
                (bits,) = struct.unpack_from("<H", data, off + BODY.size + BODY_VELOCITY.size)
                b["sources"] = [n for k, n in enumerate(SOURCE_NAMES) if bits >> k & 1]
            if not all(math.isfinite(b[k]) for k in ("x", "y", "z", "yaw", "qw", "qx", "qy", "qz", "vx", "vy", "vz",
                                                      "yaw_rate") if k in b):
                raise Malformed("non-finite body pose")
            bodies.append(b)
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
        if sources:
            bits, mflags = SOURCES.unpack_from(data, off + RECORD.size + VELOCITY.size)
            m["sources"] = [n for i, n in enumerate(SOURCE_NAMES) if bits >> i & 1]
            m["has_yaw"] = bool(mflags & MARKER_HAS_YAW)
        if not all(math.isfinite(m[k]) for k in ("x", "y", "z", "yaw")):
            raise Malformed("non-finite position")
        markers.append(m)
    return {"type": "ips.positions", "version": version, "seq": seq, "update": update,
            "part": part, "parts": parts, "t_capture_real_ns": t_real,
            "t_capture_mono_ns": t_mono, "t_publish_real_ns": t_pub,
            "velocity": velocity, **({"sources": True} if sources else {}), "markers": markers, **({"bodies": bodies} if version == 2 else {})}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bind", default="0.0.0.0", help="local address to receive on")
    ap.add_argument("--port", type=int, default=5005)
    ap.add_argument("--group", help="multicast group to join")
    ap.add_argument("--count", type=int, default=0, help="stop after N valid datagrams")
    ap.add_argument("--subscribe", metavar="HOST:PORT", help="ask a daemon's subscriptions output for a stream")
    ap.add_argument("--ids", default="", help="with --subscribe: comma-separated marker ids (default all)")
    ap.add_argument("--format", choices=("binary", "json"), default="binary", help="with --subscribe")
    ap.add_argument("--lease", type=int, default=30, help="with --subscribe: lease seconds")
    ap.add_argument("--psk", default="", help="with --subscribe: the output's pre-shared key")
    args = ap.parse_args()

    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sub = None
    if args.subscribe:
        host, _, port = args.subscribe.rpartition(":")
        sock.bind((args.bind, 0))  # any free port: the daemon streams to where we asked from
        ids = [int(i) for i in args.ids.split(",") if i]
        sub = Subscription(sock, (socket.gethostbyname(host), int(port)), ids, args.format, args.lease, args.psk)
        sock.settimeout(0.2)
    else:
        sock.bind(("0.0.0.0" if args.group else args.bind, args.port))
    if args.group:
        mreq = struct.pack("4s4s", socket.inet_aton(args.group), socket.inet_aton("0.0.0.0"))
        sock.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, mreq)

    valid = malformed = 0
    try:
        while args.count == 0 or valid < args.count:
            if sub:
                sub.due()
                try:
                    data, _ = sock.recvfrom(65536)
                except socket.timeout:
                    continue
                if sub.reply(data):
                    continue
            else:
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
                if "ranges" in m.get("sources", []):
                    line += "  +ranges" if m["cameras"] else "  ranges"
                if d["velocity"]:
                    line += f"  v ({m['vx']:.2f}, {m['vy']:.2f}) m/s"
                print(line, flush=True)
            for b in d.get("bodies", []):
                held = not b["has_yaw"] and "ranges" in b.get("sources", [])  # ranges alone: yaw held
                yaw = (f"{math.degrees(b['yaw']):7.1f} deg" + (" (held)" if held else "")
                       if b["has_yaw"] or held else "      - deg")
                print(f"seq {d['seq']:6d}  body {b['name']}  x {b['x']:7.3f}  y {b['y']:7.3f}  z {b['z']:6.3f} m  "
                      f"yaw {yaw}  q ({b['qw']:.3f} {b['qx']:.3f} {b['qy']:.3f} {b['qz']:.3f})  "
                      f"ids {','.join(str(i) for i in b['ids'])}  cams 0x{b['cameras']:02x}"
                      + (" + ranges" if b["cameras"] and "ranges" in b.get("sources", []) else
                         " ranges" if "ranges" in b.get("sources", []) else "")
                      + f"  age {age_ms:6.1f} ms"
                      + (f"  v ({b['vx']:.2f}, {b['vy']:.2f}) m/s" if "vx" in b else "")
                      + (f"  yaw rate {math.degrees(b['yaw_rate']):.1f} deg/s" if "yaw_rate" in b else ""),
                      flush=True)
    except KeyboardInterrupt:
        pass
    if sub:
        sub.close()
    print(f"{valid} datagrams, {malformed} malformed", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
