"""Third-party checks of `petriplc run` with an opcua_server and of `petriplc user` (tests/opcua.rs):
Python asyncua 2.1.0 (pinned in scripts/test-all.sh) as the client, Python's pty for a terminal.

    opcua_client.py sessions URL N                 N sessions at once, each reads and closes
    opcua_client.py login URL USER PASSWORD        a session as USER, reads a point
    opcua_client.py refused URL USER PASSWORD      a session as USER is refused
    opcua_client.py tty PETRIPLC FILE NAME CASE    `petriplc user add FILE NAME` in a terminal

Prints one JSON object on the last line of standard output; exits 1 with a message when a
check fails.
"""

import asyncio
import fcntl
import json
import os
import select
import subprocess
import sys
import termios
import time

from asyncua import Client, ua


def fail(message):
    print(f"FAILED: {message}", file=sys.stderr)
    sys.exit(1)


def expect(cond, message):
    if not cond:
        fail(message)


async def one_session(url, i):
    async with Client(url=url, timeout=10) as client:
        state = await client.nodes.server_state.read_value()
        expect(state == ua.ServerState.Running, f"session {i}: server state {state}")


async def sessions(url, n):
    await asyncio.gather(*(one_session(url, i) for i in range(n)))
    print(json.dumps({"sessions": n}))


def user_client(url, user, password):
    client = Client(url=url, timeout=10)
    client.set_user(user)
    client.set_password(password)
    return client


async def login(url, user, password):
    async with user_client(url, user, password) as client:
        state = await client.nodes.server_state.read_value()
        expect(state == ua.ServerState.Running, f"server state {state}")
    print(json.dumps({"login": user}))


async def refused(url, user, password):
    try:
        async with user_client(url, user, password):
            pass
    except ua.UaStatusCodeError as e:
        name = ua.StatusCode(e.code).name
        expect(name in ("BadUserAccessDenied", "BadIdentityTokenRejected"), f"refused with {name}")
        print(json.dumps({"refused": name}))
        return
    fail(f"user {user} logged in with a wrong password")


def tty(petriplc, file, name, case):
    """Runs `petriplc user add FILE NAME --cost 4` on a new pseudo-terminal and types:
    `same` the same password twice, `differ` two different ones, `interrupt` Ctrl-C at the
    first prompt. Checks that nothing typed is echoed and that the terminal echoes again
    afterwards."""
    master, slave = os.openpty()

    def controlling_terminal():
        # A session of its own with the pty as its terminal: Ctrl-C there is its SIGINT.
        fcntl.ioctl(0, termios.TIOCSCTTY, 0)

    child = subprocess.Popen([petriplc, "user", "add", file, name, "--cost", "4"],
                             stdin=slave, stdout=slave, stderr=slave, start_new_session=True,
                             preexec_fn=controlling_terminal)
    seen = b""

    def read_until(want, limit=30):
        nonlocal seen
        deadline = time.time() + limit
        while want not in seen:
            expect(time.time() < deadline, f"no {want!r} in {seen!r}")
            r, _, _ = select.select([master], [], [], 0.1)
            if r:
                try:
                    seen += os.read(master, 1024)
                except OSError:
                    break

    secret = "s3cret-typed"
    read_until(b"password for " + name.encode() + b": ")
    if case == "interrupt":
        os.write(master, b"\x03")
    else:
        os.write(master, secret.encode() + b"\n")
        read_until(b"again: ")
        os.write(master, (secret if case == "same" else "other").encode() + b"\n")
    rc = child.wait(timeout=60)
    echo = bool(termios.tcgetattr(slave)[3] & termios.ECHO)
    try:
        while select.select([master], [], [], 0.2)[0]:
            seen += os.read(master, 1024)
    except OSError:
        pass
    text = seen.decode(errors="replace")
    expect(secret not in text, f"the password was echoed: {text!r}")
    expect(echo, "the terminal does not echo any more")
    print(json.dumps({"rc": rc, "output": text}))


def main():
    what = sys.argv[1]
    if what == "sessions":
        asyncio.run(sessions(sys.argv[2], int(sys.argv[3])))
    elif what == "login":
        asyncio.run(login(sys.argv[2], sys.argv[3], sys.argv[4]))
    elif what == "refused":
        asyncio.run(refused(sys.argv[2], sys.argv[3], sys.argv[4]))
    elif what == "tty":
        tty(sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5])
    else:
        fail(f"unknown check {what}")


if __name__ == "__main__":
    main()
