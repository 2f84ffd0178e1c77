"""The simulation's writer to the drawing process (render/draw_process.py, `_Sender`): a message is
written on a thread of its own, so putting one never waits for a reader that is busy, and the reader
gets every message, in order, as Connection.send would have written it."""

from __future__ import annotations

import socket
import threading
from multiprocessing.connection import Connection

import numpy as np

from render.draw_process import _Sender

BIG = 8 << 20  # bytes: many times a socket's buffer, so a blocking write would wait for the reader


def _pair() -> tuple[Connection, Connection]:
    a, b = socket.socketpair()
    return Connection(a.detach()), Connection(b.detach())


def test_putting_a_message_does_not_wait_for_the_reader_and_order_is_kept():
    mine, theirs = _pair()
    sender = _Sender(mine)
    payload = np.arange(BIG // 8, dtype=np.float64)
    done = threading.Event()

    def put_all():
        sender.put(("blocks", payload))
        payload[:] = -1.0  # the caller changes its array once put: the message keeps what was put
        sender.put(("call", ("update", ())))
        done.set()

    threading.Thread(target=put_all, daemon=True).start()
    assert done.wait(5.0)  # the reader has read nothing yet
    what, data = theirs.recv()
    assert what == "blocks" and data[0] == 0.0 and data[-1] == BIG // 8 - 1
    assert theirs.recv() == ("call", ("update", ()))
    assert sender.stop(5.0) and sender.error is None
    mine.close()
    theirs.close()


def test_a_reader_that_ended_is_reported_and_the_rest_dropped():
    mine, theirs = _pair()
    sender = _Sender(mine)
    theirs.close()
    sender.put(("blocks", np.zeros(BIG // 8)))
    sender.put(("draw", None))
    assert sender.stop(5.0)  # the thread ends: the failed write did not block it
    assert isinstance(sender.error, OSError)
    mine.close()
