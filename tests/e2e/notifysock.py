#!/usr/bin/python3
"""A stand-in for systemd's notify socket (sd_notify(3)), for tests.

Usage: notifysock.py SOCKET_PATH LOG_PATH

Binds a Unix datagram socket at SOCKET_PATH and appends every datagram it
receives to LOG_PATH, one assignment (VAR=VALUE) per line, flushed at once
so the test can poll the file.  It runs until the test kills it by PID.
"""
import os
import socket
import sys


def main():
    path, log = sys.argv[1], sys.argv[2]
    s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    s.bind(path)
    with open(log, "a", encoding="utf-8") as out:
        # the bound socket is the readiness signal the test waits for
        out.write("LISTENING=1\n")
        out.flush()
        while True:
            data = s.recv(65536)
            for line in data.decode("utf-8", "replace").split("\n"):
                if line:
                    out.write(line + "\n")
            out.flush()
            os.fsync(out.fileno())


if __name__ == "__main__":
    main()
