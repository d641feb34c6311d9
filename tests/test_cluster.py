"""dask_client against addresses that are not a working dask scheduler (hostile round four, B3):
each ends in one ParameterError naming the address within the timeout, never a hang or a
MemoryError traceback."""

import socket
import threading
import time

import pytest

from granalytics.base.cluster import dask_client
from granalytics.base.errors import ParameterError


def _server(reply: bytes | None):
    """A TCP server on a free port that accepts and then says ``reply`` (or nothing); its address."""
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(5)
    held = []

    def serve():
        while True:
            try:
                conn, _ = listener.accept()
            except OSError:
                return
            held.append(conn)
            if reply:
                conn.sendall(reply)

    threading.Thread(target=serve, daemon=True).start()
    return f"tcp://127.0.0.1:{listener.getsockname()[1]}", listener


@pytest.mark.parametrize("reply, words", [
    (None, "no dask scheduler answered at"),
    (b"HTTP/1.1 200 OK\r\nContent-Length: 5\r\n\r\nhello" * 100, "is not a dask scheduler"),
])
def test_something_else_at_the_address_is_refused_within_the_timeout(reply, words):
    import distributed  # noqa: F401  (imported before the clock starts: seconds on a loaded machine)

    address, listener = _server(reply)
    start = time.monotonic()
    try:
        with pytest.raises(ParameterError, match=words):
            with dask_client(address, timeout_s=2):
                pass
    finally:
        listener.close()
    assert time.monotonic() - start < 15


def test_a_scheduler_without_workers_is_refused_within_the_timeout():
    import logging

    from distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=False, dashboard_address=":0", silence_logs=logging.ERROR) as cluster:
        with pytest.raises(ParameterError, match="has no workers"):
            with dask_client(cluster.scheduler_address, timeout_s=2):
                pass
