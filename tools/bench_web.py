#!/usr/bin/env python3
"""Web view load benchmark: ipsd on config/demo.yaml (three synthetic cameras, web view on),
then N stream clients (what the page's EventSource does) for a while, a few of them also
pulling camera views at the page's rate, one client that never reads; then every client is
cut with a TCP reset. Reports the cameras' fps (from /status.json) before / during / after,
ipsd's resident memory over time, messages and drops, and whether ipsd is still running.

  python3 tools/bench_web.py [--clients 20] [--seconds 60] [--baseline 20]
Needs build/release/ipsd and build/demo/model.json. tools/demo.sh makes the model, and builds
ipsd in build/release only when that is configured already (tools/test.sh); on a fresh clone it
builds build/programs instead, so configure build/release first (docs/building.md).
"""
import argparse
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def http_get(port, path, timeout=5.0):
    s = socket.create_connection(("127.0.0.1", port), timeout=timeout)
    s.sendall(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n".encode())
    data = b""
    while True:
        chunk = s.recv(65536)
        if not chunk:
            break
        data += chunk
    s.close()
    head, _, body = data.partition(b"\r\n\r\n")
    return int(head[9:12]), body


def status(port):
    return json.loads(http_get(port, "/status.json")[1])


def rss_kib(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


class StreamClient(threading.Thread):
    """Reads /events; optionally fetches /camera/<name>.jpg at `camera_fps` like the page."""

    def __init__(self, port, camera=None, camera_fps=5.0, reads=True):
        super().__init__(daemon=True)
        self.port, self.camera, self.camera_fps, self.reads = port, camera, camera_fps, reads
        self.events = 0
        self.images = 0
        self.stop = False
        self.sock = socket.create_connection(("127.0.0.1", port))
        self.sock.sendall(b"GET /events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")

    def run(self):
        next_image = time.monotonic()
        self.sock.settimeout(0.05)
        while not self.stop:
            if self.reads:
                try:
                    data = self.sock.recv(65536)
                    if not data:
                        return
                    self.events += data.count(b"event: markers")
                except socket.timeout:
                    pass
                except OSError:
                    return
            else:
                time.sleep(0.05)
            if self.camera and time.monotonic() >= next_image:
                try:
                    code, body = http_get(self.port, f"/camera/{self.camera}.jpg")
                    self.images += code == 200
                except OSError:
                    pass
                next_image += 1.0 / self.camera_fps

    def reset(self):
        self.stop = True
        try:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
            self.sock.close()
        except OSError:
            pass


def fps_of(port, seconds):
    """Mean fps per camera over `seconds` (from the frame counters)."""
    a = status(port)
    t0 = time.monotonic()
    time.sleep(seconds)
    b = status(port)
    dt = time.monotonic() - t0
    return {c["name"]: (c2["frames"] - c["frames"]) / dt for c, c2 in zip(a["cameras"], b["cameras"])}, b


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--clients", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=60)
    ap.add_argument("--baseline", type=float, default=20)
    ap.add_argument("--port", type=int, default=18080)
    args = ap.parse_args()

    work = os.path.join(ROOT, "build", "bench_web")
    os.makedirs(work, exist_ok=True)
    with open(os.path.join(ROOT, "config", "demo.yaml")) as f:
        cfg = f.read()
    cfg = cfg.replace("scenes/ou2023.yaml", os.path.join(ROOT, "config", "scenes", "ou2023.yaml"))
    cfg = cfg.replace("../build/demo/model.json", os.path.join(ROOT, "build", "demo", "model.json"))
    cfg = cfg.replace('listen: "127.0.0.1:8080"', f'listen: "127.0.0.1:{args.port}"')
    cfg = cfg.replace("socket: /tmp/ipsd-demo.sock", f"socket: {work}/status.sock")
    path = os.path.join(work, "ipsd.yaml")
    with open(path, "w") as f:
        f.write(cfg)
    log = open(os.path.join(work, "ipsd.log"), "w")
    ipsd = subprocess.Popen([os.path.join(ROOT, "build", "release", "ipsd"), "--config", path], stdout=log, stderr=log)
    try:
        for _ in range(300):
            try:
                if all(c["frames"] > 5 for c in status(args.port)["cameras"]):
                    break
            except (OSError, ValueError, KeyError):
                pass
            time.sleep(0.2)
        print(f"load average before: {os.getloadavg()}")
        base, _ = fps_of(args.port, args.baseline)
        rss0 = rss_kib(ipsd.pid)
        print(f"no clients ({args.baseline:.0f} s): fps {fmt(base)}, ipsd RSS {rss0 / 1024:.1f} MiB")

        cams = list(base.keys())
        clients = []
        for i in range(args.clients):
            # Like pages watching a camera: every fourth client also pulls camera views.
            clients.append(StreamClient(args.port, camera=cams[i % len(cams)] if i % 4 == 0 else None))
        stalled = StreamClient(args.port, reads=False)  # connected, never reads
        for c in clients + [stalled]:
            c.start()
        t0 = time.monotonic()
        rss = []
        frames0 = status(args.port)
        while time.monotonic() - t0 < args.seconds:
            time.sleep(5)
            rss.append(rss_kib(ipsd.pid))
        dt = time.monotonic() - t0
        frames1 = status(args.port)
        during = {c["name"]: (c2["frames"] - c["frames"]) / dt for c, c2 in zip(frames0["cameras"], frames1["cameras"])}
        web = frames1["web"]
        events = [c.events for c in clients]
        print(f"{args.clients} clients + 1 stalled ({args.seconds:.0f} s): fps {fmt(during)}")
        print(f"  updates received per client: min {min(events)} max {max(events)} "
              f"({min(events) / dt:.1f}-{max(events) / dt:.1f} /s); camera images: {sum(c.images for c in clients)}")
        print(f"  ipsd RSS every 5 s (MiB): {' '.join(f'{r / 1024:.1f}' for r in rss)}")
        print(f"  web counters: {json.dumps(web)}")
        print(f"  load average: {os.getloadavg()}")
        for c in clients + [stalled]:
            c.reset()
        time.sleep(3)
        after, st = fps_of(args.port, args.baseline)
        print(f"after abrupt disconnects ({args.baseline:.0f} s): fps {fmt(after)}, live streams {st['web']['clients']}, "
              f"ipsd RSS {rss_kib(ipsd.pid) / 1024:.1f} MiB, ipsd running: {ipsd.poll() is None}")
    finally:
        ipsd.send_signal(signal.SIGTERM)
        code = ipsd.wait(timeout=20)
        print(f"ipsd exit status {code}")
    return 0


def fmt(fps):
    return ", ".join(f"{k} {v:.2f}" for k, v in fps.items())


if __name__ == "__main__":
    sys.exit(main())
