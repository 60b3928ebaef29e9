#!/usr/bin/env python3
"""What idle clients cost strandcastd (not part of the test command; BENCHMARKS.md records it).

Starts the daemon on a groom of STRANDS x VERTS (CPU backend, 1 thread, --client-buffer 8192,
no groom budget), reads one hello to report its size, then opens N WebSocket clients that
never read a byte and reports the daemon's RSS --settle seconds after they are all counted
(one idle client is opened first, so the stream's one-time encoder memory is not counted) and /metrics'
strandcast_client_queued_bytes. One JSON line on stdout.

usage: tests/soak/idle_clients.py [--daemon build/strandcastd] [--strands 65536] [--verts 32] [--clients 100]
                                  [--settle 10]
"""
import argparse
import json
import re
import socket
import subprocess
import time

UPGRADE = (b'GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n'
           b'Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n'
           b'Sec-WebSocket-Protocol: strandcast.v3\r\n\r\n')


def rss_mib(pid):
    with open('/proc/%d/status' % pid) as f:
        for line in f:
            if line.startswith('VmRSS:'):
                return int(line.split()[1]) / 1024.0
    raise RuntimeError('no VmRSS')


def metric(port, name):
    s = socket.create_connection(('127.0.0.1', port))
    s.sendall(b'GET /metrics HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n')
    data = b''
    while True:
        c = s.recv(65536)
        if not c:
            break
        data += c
    s.close()
    m = re.search(r'\n' + re.escape(name) + r' (\S+)', data.decode())
    return float(m.group(1)) if m else None


def first_message_len(port):
    s = socket.create_connection(('127.0.0.1', port))
    s.sendall(UPGRADE)
    buf = b''

    def need(n):
        nonlocal buf
        while len(buf) < n:
            c = s.recv(1 << 20)
            if not c:
                raise RuntimeError('connection closed before the hello')
            buf += c
    while b'\r\n\r\n' not in buf:
        need(len(buf) + 1)
    buf = buf[buf.index(b'\r\n\r\n') + 4:]
    need(2)
    n, head = buf[1] & 127, 2
    if n == 126:
        need(4)
        n, head = int.from_bytes(buf[2:4], 'big'), 4
    elif n == 127:
        need(10)
        n, head = int.from_bytes(buf[2:10], 'big'), 10
    s.close()
    return n


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--daemon', default='build/strandcastd')
    ap.add_argument('--strands', type=int, default=65536)
    ap.add_argument('--verts', type=int, default=32)
    ap.add_argument('--clients', type=int, default=100)
    ap.add_argument('--settle', type=float, default=10.0, help='seconds to wait after the clients are counted')
    a = ap.parse_args()
    p = subprocess.Popen([a.daemon, '--port', '0', '--backend', 'cpu', '--threads', '1', '--strands', str(a.strands),
                          '--verts', str(a.verts), '--min-step-rate', '0', '--client-buffer', '8192',
                          '--max-clients', str(a.clients + 8)],
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        port = None
        while port is None:
            line = p.stdout.readline()
            if not line:
                raise RuntimeError('the daemon exited')
            m = re.search(r'http://[^:]+:(\d+)/', line)
            port = int(m.group(1)) if m else None
        hello = first_message_len(port)
        idle = []

        def open_idle(k):
            for _ in range(k):
                c = socket.create_connection(('127.0.0.1', port))
                c.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
                c.sendall(UPGRADE)
                idle.append(c)
            end = time.time() + 300
            while metric(port, 'strandcast_clients') != len(idle) and time.time() < end:
                time.sleep(0.2)
            time.sleep(a.settle)  # hellos and frames written or queued (a slow groom steps seldom)
        open_idle(1)
        rss0 = rss_mib(p.pid)
        open_idle(a.clients)
        rss1 = rss_mib(p.pid)
        print(json.dumps({'bench': 'idle_clients', 'strands': a.strands, 'verts': a.verts, 'hello_bytes': hello,
                          'clients': a.clients, 'rss_mib_before': round(rss0, 1), 'rss_mib_after': round(rss1, 1),
                          'kib_per_client': round((rss1 - rss0) * 1024 / a.clients, 1),
                          'client_queued_bytes': metric(port, 'strandcast_client_queued_bytes')}))
    finally:
        p.terminate()
        p.wait()


if __name__ == '__main__':
    main()
