"""Throwaway MongoDB wire-protocol servers for the store tests.

Two halves:

* :class:`MongoServer` (imported by test_store.py): starts a server on a free port in a temp
  dir, kills it, restarts it on the same port and data. It runs, in this order of preference,
  ``$BFS_MONGO_PYTHON`` (an interpreter with mongoeco), ``.venv-mongo/bin/python`` in the
  repository, or ``mongod`` from PATH. :func:`find_launcher` says which, or why none.
* ``python mongo_server.py --port P --db FILE`` (run by that interpreter, Python >= 3.13 with
  ``mongoeco[wire]``): a mongoeco server whose documents live in an SQLite file, so a server
  killed with SIGKILL and restarted on the same file still has every acknowledged write.
  Prints ``READY mongodb://127.0.0.1:P/`` once it accepts connections. ``--db :memory:``
  uses mongoeco's MemoryEngine instead. Both engines check ``_id`` uniqueness by scanning
  the collection (mongoeco 4.11), so single inserts slow down as a collection grows: fine
  for tests, not a stand-in for MongoDB's speed.

Set up ``.venv-mongo`` with (Debian 12 has no mongod; mongoeco needs Python >= 3.13)::

    python3.13 -m venv .venv-mongo
    .venv-mongo/bin/pip install "mongoeco[wire]==4.11.0" "pymongo==4.20.0"
"""
from __future__ import annotations

import argparse
import asyncio
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from typing import List, Optional, Tuple

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
ENABLE_HINT = ("to run them: python3.13 -m venv .venv-mongo && .venv-mongo/bin/pip install "
               "'mongoeco[wire]==4.11.0' 'pymongo==4.20.0' (in the repository root), or set "
               "BFS_MONGO_PYTHON to a Python >= 3.13 with mongoeco[wire], or put mongod on PATH")


def _mongoeco_works(python: str) -> bool:
    try:
        out = subprocess.run([python, "-c", "import mongoeco.wire.proxy, bson"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return False
    return out.returncode == 0


def find_launcher() -> Tuple[Optional[Tuple[str, str]], str]:
    """((kind, executable), "") for the first usable server, else (None, why not)."""
    explicit = os.environ.get("BFS_MONGO_PYTHON")
    if explicit:
        if _mongoeco_works(explicit):
            return ("mongoeco", explicit), ""
        return None, ("BFS_MONGO_PYTHON=%s cannot import mongoeco.wire.proxy and bson"
                      % explicit)
    venv = os.path.join(REPO, ".venv-mongo", "bin", "python")
    if os.access(venv, os.X_OK) and _mongoeco_works(venv):
        return ("mongoeco", venv), ""
    mongod = shutil.which("mongod")
    if mongod:
        return ("mongod", mongod), ""
    return None, "no MongoDB wire-protocol server (no .venv-mongo with mongoeco, no mongod)"


def free_port() -> int:
    """A TCP port nothing listens on right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class MongoServer:
    """One throwaway server process (see module doc).

    Args:
        launcher: from :func:`find_launcher`.
        workdir: holds the data and the server's log.
        port: the TCP port (default: a free one).
        memory: mongoeco only: keep documents in memory (faster, gone when killed).
    """

    def __init__(self, launcher: Tuple[str, str], workdir: str, port: int = 0,
                 memory: bool = False):
        self.kind, self.executable = launcher
        self.memory = memory
        self.workdir = workdir
        self.port = port or free_port()
        self.uri = "mongodb://127.0.0.1:%d/" % self.port
        self.log_path = os.path.join(workdir, "server.log")
        self.proc = None  # type: Optional[subprocess.Popen]

    def _command(self) -> List[str]:
        if self.kind == "mongoeco":
            return [self.executable, os.path.abspath(__file__), "--port", str(self.port),
                    "--db", ":memory:" if self.memory else os.path.join(self.workdir,
                                                                        "data.sqlite")]
        dbpath = os.path.join(self.workdir, "mongod-data")
        os.makedirs(dbpath, exist_ok=True)
        return [self.executable, "--port", str(self.port), "--bind_ip", "127.0.0.1",
                "--dbpath", dbpath, "--quiet"]

    def start(self, timeout: float = 30.0) -> "MongoServer":
        """Start the server and wait until it answers a ping."""
        import pymongo

        os.makedirs(self.workdir, exist_ok=True)
        with open(self.log_path, "ab") as log:
            # its own session: a signal to the caller's process group (roslaunch stopping a
            # test node) does not take the server down with it
            self.proc = subprocess.Popen(self._command(), stdout=log, stderr=subprocess.STDOUT,
                                         start_new_session=True)
        deadline = time.monotonic() + timeout
        while True:
            if self.proc.poll() is not None:
                raise RuntimeError("%s server exited with %s:\n%s"
                                   % (self.kind, self.proc.returncode, self.log()))
            client = pymongo.MongoClient(self.uri, serverSelectionTimeoutMS=300)
            try:
                client.admin.command("ping")
                return self
            except pymongo.errors.PyMongoError:
                if time.monotonic() > deadline:
                    self.kill()
                    raise RuntimeError("%s server on port %d did not answer within %.0f s:\n%s"
                                       % (self.kind, self.port, timeout, self.log()))
            finally:
                client.close()
            time.sleep(0.1)

    def kill(self) -> None:
        """SIGKILL: the server dies mid-whatever, as in a crash or power cut of its host."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self.proc = None

    def stop(self) -> None:
        """SIGTERM and wait (falls back to SIGKILL)."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc = None

    def log(self) -> str:
        try:
            with open(self.log_path, "r", errors="replace") as f:
                return f.read()[-4000:]
        except OSError:
            return ""


async def _serve(port: int, db: str) -> None:
    from mongoeco.engines.memory import MemoryEngine
    from mongoeco.engines.sqlite import SQLiteEngine
    from mongoeco.wire.proxy import AsyncMongoEcoProxyServer

    engine = MemoryEngine() if db == ":memory:" else SQLiteEngine(db, executor_workers=1)
    server = AsyncMongoEcoProxyServer(engine=engine, host="127.0.0.1", port=port)
    await server.start()
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, stop.set)
    print("READY mongodb://127.0.0.1:%d/" % server.address.port, flush=True)
    try:
        await stop.wait()
    finally:
        await server.close()


def main() -> int:
    parser = argparse.ArgumentParser(description="mongoeco wire-protocol server on SQLite")
    parser.add_argument("--port", type=int, default=0, help="TCP port (0: any free port)")
    parser.add_argument("--db", required=True,
                        help="SQLite file holding the documents (:memory: for none)")
    args = parser.parse_args()
    asyncio.run(_serve(args.port, args.db))
    return 0


if __name__ == "__main__":
    sys.exit(main())
