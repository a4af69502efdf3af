"""Batch ray tests through PyBullet's own C API, results straight into numpy.

``pybullet.rayTestBatch`` returns one Python tuple per ray (id, link, fraction, position,
normal: 12 Python objects). Measured here on the office world, building and unpacking them is
about 150 ns of the 600 ns a lidar ray costs with two threads. The pybullet extension module
also exports the C API it is built on (``b3CreateRaycastBatchCommandInit``,
``b3RaycastBatchAddRays``, ``b3GetRaycastInformation``...), which takes the rays as C arrays and
hands back an array of ``b3RayHitInfo`` structs: ``numpy`` reads the fractions and body ids
from it without a Python object per ray.

The one thing the C API needs that pybullet does not expose is the client handle behind a
Python client id: pybullet keeps it in its static array ``sPhysicsClients1``. Its address is
read from the extension's ELF symbol table (where pybullet's wheels keep local symbols), and
the handle is read from it at every call, so a disconnected client is never used.

Nothing here is trusted blindly: ``available()`` is False (and ``cast_rays`` keeps to
``rayTestBatch``) unless the module is an ELF file with both symbols, and the first batches
cast through the C API are cast through ``rayTestBatch`` too and must agree exactly; on any
disagreement the C path is switched off for the process, with the reason in ``status()``.
Set ``BULLET_FLOOR_SIM_RAY_CAPI=0`` to keep to ``rayTestBatch``.
"""
from __future__ import annotations

import ctypes
import mmap
import os
import struct
from typing import Dict, Optional, Sequence, Tuple, TypedDict

import numpy as np

__all__ = ["available", "cast_batch", "status", "HIT_DTYPE"]

#: struct b3RayHitInfo (SharedMemoryPublic.h): fraction, body id, link index, position, normal.
HIT_DTYPE = np.dtype([("fraction", "<f8"), ("body", "<i4"), ("link", "<i4"),
                      ("position", "<f8", (3,)), ("normal", "<f8", (3,))])
_MAX_CLIENTS = 1024        # pybullet.c MAX_PHYSICS_CLIENTS
_CHECK_HITS = 64           # rays with a hit that must have agreed before the C path is trusted
_CHECK_RAYS = 256          # rays of a batch compared while checking


class _RaycastInformation(ctypes.Structure):
    _fields_ = [("count", ctypes.c_int), ("hits", ctypes.c_void_p)]


class _CAPI:
    """ctypes bindings of the ray-test part of PyBullet's C API (see the module doc)."""

    def __init__(self, module_path: str) -> None:
        symbols = elf_symbols(module_path, ("sPhysicsClients1", "b3ConnectPhysicsDirect"))
        missing = [k for k in ("sPhysicsClients1", "b3ConnectPhysicsDirect") if k not in symbols]
        if missing:
            raise OSError("%s: no symbol %s" % (module_path, ", ".join(missing)))
        lib = ctypes.CDLL(module_path)
        vp, ci = ctypes.c_void_p, ctypes.c_int
        anchor = ctypes.cast(lib.b3ConnectPhysicsDirect, vp).value
        assert anchor is not None   # the address of a function the library exports
        self._clients = anchor - symbols["b3ConnectPhysicsDirect"] + symbols["sPhysicsClients1"]
        self._init = _fn(lib.b3CreateRaycastBatchCommandInit, vp, [vp])
        self._threads = _fn(lib.b3RaycastBatchSetNumThreads, None, [vp, ci])
        self._mask = _fn(lib.b3RaycastBatchSetCollisionFilterMask, None, [vp, ci])
        self._add = _fn(lib.b3RaycastBatchAddRays, None, [vp, vp, vp, vp, ci])
        self._submit = _fn(lib.b3SubmitClientCommandAndWaitStatus, vp, [vp, vp])
        self._status = _fn(lib.b3GetStatusType, ci, [vp])
        self._can_submit = _fn(lib.b3CanSubmitCommand, ci, [vp])
        self._info = _fn(lib.b3GetRaycastInformation, None, [vp, ctypes.POINTER(_RaycastInformation)])
        self._done_status: Optional[int] = None     # CMD_REQUEST_RAY_CAST_INTERSECTIONS_COMPLETED

    def handle(self, client_id: int) -> int:
        if not 0 <= client_id < _MAX_CLIENTS:
            raise ValueError("pybullet client id %d out of range" % client_id)
        h = ctypes.c_void_p.from_address(self._clients + ctypes.sizeof(ctypes.c_void_p) * client_id).value
        if not h or not self._can_submit(h):
            raise RuntimeError("pybullet client %d is not connected" % client_id)
        return h

    def cast(self, client_id: int, froms: np.ndarray, tos: np.ndarray, threads: int,
             mask: Optional[int]) -> Tuple[np.ndarray, np.ndarray, int]:
        """Returns (fractions, body ids, the command's status type)."""
        h = self.handle(client_id)
        froms = np.ascontiguousarray(froms, dtype=np.float64)
        tos = np.ascontiguousarray(tos, dtype=np.float64)
        m = len(froms)
        cmd = self._init(h)
        self._threads(cmd, int(threads))
        if mask is not None:
            self._mask(cmd, int(mask))
        self._add(h, cmd, froms.ctypes.data, tos.ctypes.data, m)
        st = self._status(self._submit(h, cmd))
        if self._done_status is not None and st != self._done_status:
            raise RuntimeError("ray test failed (status %d)" % st)
        info = _RaycastInformation()
        self._info(h, ctypes.byref(info))
        if info.count != m or (m and not info.hits):
            raise RuntimeError("ray test returned %d results for %d rays" % (info.count, m))
        if not m:
            return np.zeros(0), np.zeros(0, dtype=np.int64), st
        buf = (ctypes.c_char * (m * HIT_DTYPE.itemsize)).from_address(info.hits)
        # numpy's stubs list the buffer types they take, and a ctypes array is not among them
        hits = np.frombuffer(buf, dtype=HIT_DTYPE, count=m)  # type: ignore[call-overload]
        return hits["fraction"].copy(), hits["body"].astype(np.int64), st


def _fn(f, restype, argtypes):
    f.restype, f.argtypes = restype, argtypes
    return f


class _State(TypedDict):
    api: Optional[_CAPI]   # the bindings, once made and not switched off
    why: str               # how ray tests are cast, for status()
    checked_hits: int      # rays with a hit that agreed with rayTestBatch so far


_state: _State = {"api": None, "why": "not tried yet", "checked_hits": 0}


def _api() -> Optional[_CAPI]:
    if _state["api"] is None and _state["why"] == "not tried yet":
        if os.environ.get("BULLET_FLOOR_SIM_RAY_CAPI", "1").strip() in ("0", "false", "no"):
            _state["why"] = "switched off by BULLET_FLOOR_SIM_RAY_CAPI"
            return None
        try:
            import pybullet
            _state["api"] = _CAPI(pybullet.__file__)
            _state["why"] = "checking against rayTestBatch"
        except (OSError, AttributeError, ValueError, struct.error) as e:
            _state["why"] = "unavailable: %s" % e
    return _state["api"]


def available() -> bool:
    """Whether ray tests may go through the C API (it may still be switched off later, if
    one of the checked batches disagrees with rayTestBatch)."""
    return _api() is not None


def status() -> str:
    """How ray tests are cast, for logs and the benchmark."""
    api = _api()
    if api is None:
        return "rayTestBatch (C API %s)" % _state["why"]
    return "C API (%s)" % _state["why"]


def cast_batch(client, froms: np.ndarray, tos: np.ndarray, threads: int,
               mask: Optional[int] = None) -> Optional[Tuple[np.ndarray, np.ndarray]]:
    """One batch of at most ``MAX_RAYS_PER_BATCH`` rays through the C API.

    Returns:
        (hit fractions, hit body ids) as ``rayTestBatch`` would give them, or None when the
        C path is not available (then the caller uses rayTestBatch).
    """
    api = _api()
    if api is None:
        return None
    cid = int(getattr(client, "_client", 0))
    frac, ids, st = api.cast(cid, froms, tos, threads, mask)
    if _state["checked_hits"] < _CHECK_HITS:
        k = min(len(froms), _CHECK_RAYS)
        kw = {} if mask is None else {"collisionFilterMask": int(mask)}
        ref = client.rayTestBatch(froms[:k], tos[:k], numThreads=int(threads), **kw)
        ref_frac = np.array([r[2] for r in ref], dtype=float)
        ref_ids = np.array([r[0] for r in ref], dtype=np.int64)
        if not (np.array_equal(ref_frac, frac[:k]) and np.array_equal(ref_ids, ids[:k])):
            _state["api"], _state["why"] = None, "off: disagreed with rayTestBatch"
            return None
        if api._done_status is None and k:
            api._done_status = st
        _state["checked_hits"] = int(_state["checked_hits"]) + int(np.count_nonzero(ref_ids >= 0))
        if _state["checked_hits"] >= _CHECK_HITS:
            _state["why"] = "checked against rayTestBatch"
    return frac, ids


def elf_symbols(path: str, names: Sequence[str]) -> Dict[str, int]:
    """Values (addresses relative to the load base) of the named symbols in a 64-bit
    little-endian ELF file's ``.symtab`` or ``.dynsym`` (the file is mapped, not read: the
    pybullet module is 140 MB).

    Raises:
        OSError: not a 64-bit little-endian ELF file.
    """
    sym = np.dtype([("name", "<u4"), ("info", "u1"), ("other", "u1"), ("shndx", "<u2"),
                    ("value", "<u8"), ("size", "<u8")])
    found: Dict[str, int] = {}
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as data:
        if data[:4] != b"\x7fELF" or data[4] != 2 or data[5] != 1:
            raise OSError("%s is not a 64-bit little-endian ELF file" % path)
        shoff, = struct.unpack_from("<Q", data, 0x28)
        shentsize, shnum = struct.unpack_from("<HH", data, 0x3A)
        sections = [struct.unpack_from("<IIQQQQIIQQ", data, shoff + i * shentsize)
                    for i in range(shnum)]
        for kind in (2, 11):     # SHT_SYMTAB, then SHT_DYNSYM
            for sec in sections:
                if sec[1] != kind or sec[9] != sym.itemsize:
                    continue
                off, size, link = sec[4], sec[5], sec[6]
                str_off, str_size = sections[link][4], sections[link][5]
                table = np.frombuffer(data, dtype=sym, count=size // sym.itemsize, offset=off)
                for name in names:
                    if name in found:
                        continue
                    key = b"\0" + name.encode() + b"\0"
                    at = data.find(key, str_off, str_off + str_size)
                    while at >= 0:
                        rows = np.flatnonzero((table["name"] == at + 1 - str_off)
                                              & (table["value"] != 0))
                        if len(rows):
                            found[name] = int(table["value"][rows[0]])
                            break
                        at = data.find(key, at + 1, str_off + str_size)
                del table
            if len(found) == len(names):
                break
    return found
