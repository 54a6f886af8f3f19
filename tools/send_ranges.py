#!/usr/bin/env python3
"""Sends one firing of a ranging tag to ipsd's range input (layout: include/ips/input/range_wire.h).

    python3 tools/send_ranges.py 192.168.1.10:5800 --tag 7 --firing 42 --ref 1:3.21 --ref 2:2.87:0.05
    python3 tools/send_ranges.py 127.0.0.1:5800 --tag 7 --firing 43 --ref tag:8:1.20 --psk "lab key"

--ref [tag:]ID:RANGE[:SIGMA] (metres; "tag:" = another tag as a mobile reference). The firing
time is this host's CLOCK_REALTIME now (--time-ns to give it, 0 = let ipsd stamp it on arrival).
"""
import argparse, hashlib, hmac, socket, struct, time

p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
p.add_argument("to", help="HOST:PORT of ipsd's ranging input")
p.add_argument("--tag", type=int, required=True)
p.add_argument("--firing", type=int, required=True, help="the tag's firing counter, +1 per firing")
p.add_argument("--ref", action="append", required=True, help="[tag:]ID:RANGE[:SIGMA]")
p.add_argument("--odometry", nargs=2, type=float, metavar=("METRES", "SIGMA"), help="distance since the last firing")
p.add_argument("--time-ns", type=int, default=None)
p.add_argument("--psk", default="")
a = p.parse_args()
entries = b""
for ref in a.ref:
    f = ref.split(":")
    is_tag = f[0] == "tag"
    f = f[1:] if is_tag else f
    entries += struct.pack("<Iff", int(f[0]) | (0x80000000 if is_tag else 0), float(f[1]), float(f[2]) if len(f) > 2 else 0.0)
t = time.time_ns() if a.time_ns is None else a.time_ns
odo = a.odometry or (0.0, 0.0)
d = struct.pack("<4sBBHIIqHHffI", b"IPSR", 1, 1 if a.odometry else 0, len(a.ref), a.tag, a.firing, t, 12, 0, *odo, 0) + entries
if a.psk:
    d += hmac.new(a.psk.encode(), d, hashlib.sha256).digest()
host, port = a.to.rsplit(":", 1)
socket.socket(socket.AF_INET, socket.SOCK_DGRAM).sendto(d, (host, int(port)))
