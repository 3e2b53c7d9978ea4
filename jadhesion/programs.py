"""Exported programs kept on disk, so a new process calls a JAX program without tracing it again.

A process that traces and lowers a program once keeps it (``jax.export``, serialised StableHLO)
in a :class:`ProgramCache` directory; a later process deserialises and calls it, and JAX's
persistent compilation cache (:func:`jadhesion.config.enable_compilation_cache`) supplies the
compiled executable. The caller needs only ``jax`` and ``numpy`` to find a kept program: the code
that defines it is imported (by the ``make_fn`` the caller passes) only on a miss.

A program is kept under a key made of its name, its static options, the shapes, dtypes and tree
structure of its arguments, a code key (:func:`code_key`: a hash of the sources that define it and
the versions of the libraries it is built from), the jax/jaxlib versions, the x64 flag and the
platform. One file a key, ``<name>-<hash>.jaxexport``: a JSON header line (the key and the
SHA-256 of the serialised program) followed by the bytes of ``Exported.serialize()``. Files are
written atomically (temporary file, then rename); a file that is unreadable, corrupt, or whose
header names another key is ignored and rebuilt, never an error.

Arguments may be any pytree of arrays (they are flattened before export); the result must be a
tree ``jax.export`` serialises natively (dicts, tuples, lists, ``None``, arrays).

Compiled executables are kept by JAX's persistent cache, not here: a call of a kept program still
lowers a small wrapper around the deserialised StableHLO (about 0.03 s for the fit's program)
before the cache hands over the executable. That lowering (``jax.export``'s ``call_exported``
rule) sets up JAX's CPU LAPACK kernels for every program, whether it calls LAPACK or not, and the
set-up imports ``scipy.linalg`` (0.12–0.2 s). A program whose StableHLO names no LAPACK routine
needs no kernels, so :class:`Program` skips that step for it (:func:`_lapack_setup_skipped`); the
fit's programs do their linear algebra in :mod:`jadhesion.identify.small_linalg` for this reason.

Keeping the executables themselves (``jax.experimental.serialize_executable``) would skip that
lowering, but with jax/jaxlib 0.10.2 on CPU a fit program deserialised in a new process crashed
it (segmentation fault) or failed at its first call (``NOT_FOUND: Function
slice_subtract_fusion.2 not found``); a toy function round-tripped. Checked 2026-11, not used.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.metadata
import json
from pathlib import Path
from typing import Any, Callable, Optional

import jax
import jaxlib
import numpy as np
from jax import export
from jax._src.export import _export

from .atomic import atomic_write

#: Version of the file layout; bump it when the header or the key changes meaning.
FORMAT = 1
_SUFFIX = ".jaxexport"
_PACKAGE = Path(__file__).resolve().parent


def code_key(sources=(), distributions=()) -> str:
    """A hash of the jadhesion sources that define a program and of the installed versions of the
    distributions it is built from.

    ``sources``: paths relative to the ``jadhesion`` package — files or folders (every ``*.py``
    inside, recursively); ``distributions``: names such as ``"optimistix"`` (their versions are read
    from the installed metadata, without importing them).
    """
    h = hashlib.sha256()
    for rel in sources:
        path = _PACKAGE / rel
        files = sorted(path.rglob("*.py")) if path.is_dir() else [path]
        for f in files:
            h.update(str(f.relative_to(_PACKAGE)).encode())
            h.update(f.read_bytes())
    for dist in distributions:
        try:
            version = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            version = "absent"
        h.update(f"{dist}=={version}".encode())
    return h.hexdigest()


def _leaf_spec(x) -> list:
    return [list(np.shape(x)), str(jax.numpy.result_type(x))]


def _environment() -> dict:
    return {
        "jax": jax.__version__,
        "jaxlib": jaxlib.__version__,
        "x64": bool(jax.config.jax_enable_x64),
        "platform": export.default_export_platform(),
    }


@contextlib.contextmanager
def _lapack_setup_skipped(exported: export.Exported):
    """While lowering a call of ``exported``, skip JAX's CPU LAPACK set-up (and so the import of
    ``scipy.linalg``) if its StableHLO names no LAPACK routine (custom-call targets ``lapack_*``;
    any mention keeps the set-up). JAX calls the set-up from a private function,
    ``jax._src.export._export._ensure_backends_initialized``; without that name (another JAX) the
    call is left as it is."""
    setup = getattr(_export, "_ensure_backends_initialized", None)
    if setup is None or b"lapack" in exported.mlir_module_serialized:
        yield
        return
    _export._ensure_backends_initialized = lambda platforms: None
    try:
        yield
    finally:
        _export._ensure_backends_initialized = setup


class Program:
    """A deserialised program: call it with arguments of the tree structure, shapes and dtypes it
    was exported for; returns its result tree (JAX arrays)."""

    def __init__(self, exported: export.Exported, in_tree):
        self.exported, self.in_tree = exported, in_tree

    def __call__(self, *args):
        leaves, tree = jax.tree.flatten(args)
        if tree != self.in_tree:
            raise TypeError(f"program {self.exported.fun_name}: arguments {tree}, expected {self.in_tree}")
        with _lapack_setup_skipped(self.exported):
            return self.exported.call(*leaves)


class ProgramCache:
    """Exported programs in ``directory`` (created on first write).

    :meth:`load` finds a kept program (``None`` when there is none or it is unusable; the reason is
    kept in :attr:`last_miss`); :meth:`get_or_export` loads it or, on a miss, calls ``make_fn()`` for
    the function, traces, exports and keeps it.
    """

    def __init__(self, directory):
        self.directory = Path(directory)
        self.last_miss: Optional[str] = None

    def key(self, name: str, args: tuple, *, static: Optional[dict] = None, code: str = "") -> dict:
        """The key of program ``name`` for ``args`` (a tuple of pytrees of arrays)."""
        leaves, tree = jax.tree.flatten(args)
        return {
            "format": FORMAT,
            "name": name,
            "static": dict(static or {}),
            "code": code,
            **_environment(),
            "tree": str(tree),
            "args": [_leaf_spec(x) for x in leaves],
        }

    def path(self, key: dict) -> Path:
        """The file that holds the program of ``key``."""
        digest = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:24]
        return self.directory / f"{key['name']}-{digest}{_SUFFIX}"

    def load(
        self, name: str, args: tuple, *, static: Optional[dict] = None, code: str = ""
    ) -> Optional[Program]:
        """The kept program for these arguments, or ``None`` (missing, unreadable, corrupt, or kept
        under another key)."""
        key = self.key(name, args, static=static, code=code)
        path = self.path(key)
        try:
            raw = path.read_bytes()
        except OSError:
            self.last_miss = "missing"
            return None
        try:
            header, _, blob = raw.partition(b"\n")
            meta = json.loads(header)
            if meta.get("key") != json.loads(json.dumps(key)):
                self.last_miss = "key mismatch"
                return None
            if meta.get("sha256") != hashlib.sha256(blob).hexdigest():
                self.last_miss = "corrupt"
                return None
            exported = export.deserialize(bytearray(blob))
        except Exception as exc:  # any damage means "not kept": the caller rebuilds it
            self.last_miss = f"unreadable ({type(exc).__name__})"
            return None
        self.last_miss = None
        return Program(exported, jax.tree.structure(args))

    def export(
        self, name: str, fn: Callable, args: tuple, *, static: Optional[dict] = None, code: str = ""
    ) -> Program:
        """Trace and export ``fn(*args)`` (``fn`` closes over the static options), keep it, and
        return it. A program that cannot be serialised (e.g. ``flatbuffers`` missing) is returned
        unkept."""
        leaves, tree = jax.tree.flatten(args)

        def flat(*xs):
            return fn(*jax.tree.unflatten(tree, xs))

        exported = export.export(jax.jit(flat))(*leaves)
        key = self.key(name, args, static=static, code=code)
        try:
            blob = bytes(exported.serialize())
        except Exception as exc:  # serialisation unavailable: still usable in this process
            self.last_miss = f"not kept ({type(exc).__name__}: {exc})"
            return Program(exported, tree)
        header = json.dumps({"key": key, "sha256": hashlib.sha256(blob).hexdigest()}, sort_keys=True)
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            atomic_write(self.path(key), lambda tmp: tmp.write_bytes(header.encode() + b"\n" + blob))
        except OSError as exc:  # a read-only cache never stops a computation
            self.last_miss = f"not kept ({exc})"
        return Program(exported, tree)

    def get_or_export(
        self,
        name: str,
        make_fn: Callable[[], Callable],
        args: tuple,
        *,
        static: Optional[dict] = None,
        code: str = "",
    ) -> Program:
        """The kept program, else ``make_fn()``'s function exported (and kept) now."""
        program = self.load(name, args, static=static, code=code)
        if program is None:
            program = self.export(name, make_fn(), args, static=static, code=code)
        return program

    def remember(self, name: str, key: dict, compute: Callable[[], Any]) -> Any:
        """A JSON value kept under ``name`` and ``key`` (floats round-trip exactly): read back, or
        ``compute()``d and kept. For small results that cost a process many eager JAX operations."""
        full = {"format": FORMAT, "name": name, **_environment(), **key}
        digest = hashlib.sha256(json.dumps(full, sort_keys=True).encode()).hexdigest()[:24]
        path = self.directory / f"{name}-{digest}.json"
        try:
            doc = json.loads(path.read_text())
            if doc["key"] == json.loads(json.dumps(full)):
                return doc["value"]
        except (OSError, ValueError, KeyError, TypeError):
            pass
        value = compute()
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            atomic_write(
                path, lambda tmp: tmp.write_bytes(json.dumps({"key": full, "value": value}).encode())
            )
        except OSError:
            pass
        return value
