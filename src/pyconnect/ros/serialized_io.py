"""Publish serialized (CDR) messages through rcl itself: one copy of the data less than rclpy.

rclpy's ``publish(bytes)`` converts the bytes to a ``std::string`` (a copy: 0.4-0.7 ms for a
1080p image) before ``rcl_publish_serialized_message``, holding the GIL throughout.
``publish_serialized`` hands rcl a pointer into the ``bytes`` instead, and lets go of the GIL
while Fast DDS copies and sends. It calls rcl with ``ctypes`` on the library rclpy already
loaded, through the ``pointer`` rclpy gives for its publisher, inside the handle's context
(rclpy's guard against a destroyed publisher). When the library or a symbol is missing, or the
call fails, rclpy's ``publish`` is called instead (same result, same errors).

(The take side cannot be shortened the same way: the agents' executor is rclpy's C++
``EventsExecutor`` (pyconnect.ros.agent_executor), which takes each message through rclpy's C++
``take_message`` itself; a Python subclass of rclpy's subscription handle that overrides
``take_message`` is never asked (tried with the 7.1.6 wheel). A large message's one copy there is
the ``bytes`` rclpy makes, which ``raw_path.writable_buffer`` then uses in place.)
"""

from __future__ import annotations

import ctypes
import os
from typing import Any

_RCL_RET_OK = 0

DIRECT_FROM_BYTES = 64 * 1024
"""Messages at least this large go through rcl directly. Below, rclpy's copy costs less than
building the ctypes call (a 112-byte message: 4.7 µs through rclpy, 5-8 µs through ctypes)."""


class _Allocator(ctypes.Structure):
    """rcutils_allocator_t."""

    _fields_ = (
        ("allocate", ctypes.c_void_p),
        ("deallocate", ctypes.c_void_p),
        ("reallocate", ctypes.c_void_p),
        ("zero_allocate", ctypes.c_void_p),
        ("state", ctypes.c_void_p),
    )


class _SerializedMessage(ctypes.Structure):
    """rcl_serialized_message_t (rcutils_uint8_array_t)."""

    _fields_ = (
        ("buffer", ctypes.c_void_p),
        ("buffer_length", ctypes.c_size_t),
        ("buffer_capacity", ctypes.c_size_t),
        ("allocator", _Allocator),
    )


class _Rcl:
    """rcl's serialized publish and rcutils' error reset, from the libraries rclpy loaded."""

    def __init__(self) -> None:
        # RTLD_NOLOAD: the very libraries rclpy loaded (its handles belong to them), or none.
        rcl = ctypes.CDLL("librcl.so", mode=os.RTLD_NOLOAD)
        rcutils = ctypes.CDLL("librcutils.so", mode=os.RTLD_NOLOAD)
        self.publish = rcl.rcl_publish_serialized_message
        self.publish.argtypes = (
            ctypes.c_void_p,
            ctypes.POINTER(_SerializedMessage),
            ctypes.c_void_p,
        )
        self.publish.restype = ctypes.c_int
        self.reset_error = rcutils.rcutils_reset_error
        self.reset_error.argtypes = ()
        self.reset_error.restype = None


_loaded: list[_Rcl | None] = []


def _rcl() -> _Rcl | None:
    """rcl's functions, or None when they cannot be loaded (then rclpy's calls are used)."""
    if not _loaded:
        import rclpy.impl.implementation_singleton  # noqa: F401 (loads librcl for ctypes)

        try:
            _loaded.append(_Rcl())
        except (OSError, AttributeError):
            _loaded.append(None)
    return _loaded[0]


def publish_serialized(publisher: Any, data: bytes) -> None:
    """``publisher.publish(data)`` for CDR ``bytes``, without copying them first."""
    if len(data) < DIRECT_FROM_BYTES:
        publisher.publish(data)
        return
    rcl = _rcl()
    if rcl is None or type(data) is not bytes:
        publisher.publish(data)
        return
    buffer = ctypes.c_char_p(data)  # points into ``data``; kept alive until the call returns
    message = _SerializedMessage(
        ctypes.cast(buffer, ctypes.c_void_p), len(data), len(data), _Allocator()
    )
    handle = publisher.handle
    with handle:
        if rcl.publish(handle.pointer, ctypes.byref(message), None) == _RCL_RET_OK:
            return
        rcl.reset_error()
    publisher.publish(data)  # rclpy's own call raises rclpy's error for this publisher
