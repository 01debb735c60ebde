#!/usr/bin/env python3
"""Probes a running strata-server's web viewer the way a hostile or broken client would, and
prints what another client sees meanwhile (docs/benchmarks.md, "Hostile input").

  bench/http_probe.py --port 8080 silent --connections 200
      opens CONNECTIONS connections from 127.0.0.2 that send nothing, then times how long a
      client on 127.0.0.1 waits for the page (GET /), and how many of the silent connections
      the server closed at once.
  bench/http_probe.py --port 8080 getmap --calls 20 --map demo
      calls the JSON API's GetMap CALLS times in a row and prints each HTTP status (000: no
      answer); run against a server started with --map-store.

Standard library only; the server must listen on 0.0.0.0 or 127.0.0.1.
"""
import argparse
import select
import socket
import sys
import time


def get(port, path, timeout_s, body=None):
    """One HTTP/1.0 exchange with 127.0.0.1: (status or 0, seconds waited)."""
    start = time.monotonic()
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=timeout_s) as s:
            if body is None:
                request = f"GET {path} HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n".encode()
            else:
                data = body.encode()
                request = (f"POST {path} HTTP/1.0\r\nHost: 127.0.0.1\r\n"
                           f"Content-Type: application/json\r\nContent-Length: {len(data)}\r\n\r\n"
                           ).encode() + data
            s.sendall(request)
            answer = b""
            while True:
                chunk = s.recv(65536)
                if not chunk:
                    break
                answer += chunk
    except OSError:
        return 0, time.monotonic() - start
    status = int(answer[9:12]) if answer.startswith(b"HTTP/1.") and len(answer) >= 12 else 0
    return status, time.monotonic() - start


def silent(args):
    held = []
    for _ in range(args.connections):
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.bind(("127.0.0.2", 0))
        s.setblocking(False)
        try:
            s.connect(("127.0.0.1", args.port))
        except BlockingIOError:
            pass
        held.append(s)
    time.sleep(0.5)  # Let the server see them all before the real client comes.
    status, waited = get(args.port, "/", args.timeout_s)
    closed = 0
    for s in held:
        readable, _, _ = select.select([s], [], [], 0)
        try:
            if readable and s.recv(1) == b"":
                closed += 1
        except OSError:
            closed += 1
    print(f"silent connections: {args.connections} from 127.0.0.2, closed by the server at "
          f"once: {closed}")
    print(f"GET / from 127.0.0.1: status {status:03d} after {waited * 1000:.1f} ms"
          f" (gave up after {args.timeout_s:.0f} s)" if status == 0 else
          f"GET / from 127.0.0.1: status {status:03d} after {waited * 1000:.1f} ms")
    for s in held:
        s.close()
    return 0 if status == 200 else 1


def getmap(args):
    statuses = []
    for _ in range(args.calls):
        status, _ = get(args.port, "/api/strata.v1.MapService/GetMap", args.timeout_s,
                        body='{"map_id":"%s"}' % args.map)
        statuses.append(f"{status:03d}")
    print("GetMap statuses:", " ".join(statuses))
    return 0 if all(s == "200" for s in statuses) else 1


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--port", type=int, required=True, help="the viewer's --http-port")
    parser.add_argument("--timeout-s", type=float, default=60, help="longest wait per request")
    commands = parser.add_subparsers(dest="command", required=True)
    s = commands.add_parser("silent")
    s.add_argument("--connections", type=int, default=200)
    g = commands.add_parser("getmap")
    g.add_argument("--calls", type=int, default=20)
    g.add_argument("--map", default="demo")
    args = parser.parse_args()
    return silent(args) if args.command == "silent" else getmap(args)


if __name__ == "__main__":
    sys.exit(main())
