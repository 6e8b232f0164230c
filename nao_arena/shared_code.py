"""Shared callees: a large kernel's machine code is made once and called, not copied.

numba links the code of every compiled function a kernel calls into that kernel's own
code, then optimises and generates machine code for the whole again: each callee is
compiled once more in every caller, and its callees in every caller of theirs. For a
small callee that is what makes it cheap (it is inlined). For a large one it is most of
what a first run pays: the kernels of a NAO episode compiled in about 37 s of CPU, of
which about 8 s went to callees compiled again inside their callers.

So when the package's kernels compile (:class:`nao_arena.jit.Kernel`), a callee of the
package whose code, its linked callees' copies included, has at least
:data:`SHARED_INSTRUCTIONS` LLVM instructions is *shared*: the caller declares it and
calls it where it already is in this process (its own compiled or loaded code, by its
symbol), and keeps a :class:`LoadCallee` among its reload functions. numba runs those
before it loads the caller's machine code from the cache in a later process, so the
callee is there before the caller's call to it is bound. Calls into a large function
cost the same either way (LLVM does not inline it); small callees are still linked and
inlined. Other numba code (a user's ``njit`` function calling a kernel, the twins of
:func:`nao_arena.jit.inner_kernel`) links as numba does.

When the callee cannot be loaded as the caller was compiled against (the cache lacks it,
for instance after its source changed, or it would get another symbol), loading the
caller raises :class:`SharedCalleeMissing`, which the kernels' cache
(:class:`KernelCache`) takes as a miss: the caller is compiled again, against the
callee as it is now. So a shared callee whose source changed is never called by stale
code, as a linked copy inside a cached caller would be.
"""

from __future__ import annotations

import threading
from contextvars import ContextVar
from dataclasses import dataclass
from importlib import import_module
from typing import Any

from numba.core import codegen
from numba.core.caching import FunctionCache

__all__ = [
    "SHARED_INSTRUCTIONS",
    "KernelCache",
    "LoadCallee",
    "SharedCalleeMissing",
    "compiling_kernels",
    "install",
    "shared_callees",
    "tag",
]

SHARED_INSTRUCTIONS = 300
"""LLVM instructions (defined functions of a callee's linking module) from which a
callee is shared rather than copied into its callers."""

_TAG = "_nao_arena_callee"
_SIZE = "_nao_arena_instructions"
_SHARED = "_nao_arena_shared"

compiling_kernels: ContextVar[bool] = ContextVar("compiling_kernels", default=False)
"""True while one of the package's kernels compiles or loads (the code finalised then
is the package's, or numba's own helpers it calls)."""


class SharedCalleeMissing(Exception):
    """A cached caller's shared callee cannot be loaded as the caller was compiled
    against: the caller's cache entry is a miss."""


@dataclass(frozen=True)
class LoadCallee:
    """A reload function of a caller's cached code: load the kernel ``module.name`` for
    the argument types ``args`` (:func:`nao_arena.kernels.type_name` texts), whose entry
    point is the symbol ``symbol``, so that its machine code is in this process before
    the caller's; :class:`SharedCalleeMissing` when it cannot be (see the module)."""

    module: str
    name: str
    args: tuple[str, ...]
    symbol: str

    def __call__(self) -> None:
        try:
            self._load()
        except SharedCalleeMissing:
            raise
        except Exception as exc:  # noqa: BLE001 - gone, changed or unreadable: a miss
            raise SharedCalleeMissing(f"{self.module}.{self.name}: {exc!r}") from exc

    def _load(self) -> None:
        from nao_arena.kernels import parse_type

        dispatcher = getattr(import_module(self.module), self.name)
        sig = tuple(parse_type(a) for a in self.args)
        cres = dispatcher.overloads.get(sig)
        if cres is None:
            # from the cache only (as numba's Dispatcher.compile loads a cached version):
            # compiled here, outside its caller's compile, it could get another symbol
            cres = dispatcher._cache.load_overload(sig, dispatcher.targetctx)
            if cres is None:
                raise SharedCalleeMissing(f"{self.module}.{self.name}{sig} is not cached")
            dispatcher.targetctx.insert_user_function(cres.entry_point, cres.fndesc, [cres.library])
            dispatcher.add_overload(cres)
        if cres.fndesc.mangled_name != self.symbol:
            raise SharedCalleeMissing(f"{self.module}.{self.name}{sig} has another symbol")


class KernelCache(FunctionCache):
    """numba's function cache, but an entry whose shared callee cannot be loaded
    (:class:`SharedCalleeMissing`) is a miss, not an error, and on a miss the shipped
    precompiled entry, if there is one, is written into the cache and loaded
    (:func:`nao_arena.precompiled.install_kernel`)."""

    def load_overload(self, sig: Any, target_context: Any) -> Any:
        try:
            cres = super().load_overload(sig, target_context)
        except SharedCalleeMissing:
            return None
        if cres is None and self._install_shipped(sig):
            try:
                cres = super().load_overload(sig, target_context)
            except SharedCalleeMissing:
                return None
        return cres

    def _install_shipped(self, sig: Any) -> bool:
        from nao_arena.kernels import type_name
        from nao_arena.precompiled import install_kernel

        func = self._py_func
        if func.__qualname__ != func.__name__:  # not a module attribute: never shipped
            return False
        try:
            args = [type_name(a) for a in sig]
        except Exception:  # noqa: BLE001 - a type without a name: never shipped
            return False
        return install_kernel(func.__module__, func.__name__, args)


def tag(cres: Any, py_func: Any) -> None:
    """Mark the code of ``cres`` (a numba compile result, compiled or loaded from the
    cache) as that of the package's kernel ``py_func``: a candidate for sharing (see the
    module). A version loaded from the cache gets back the reload functions it was saved
    with (numba runs them but does not keep them on its code library), so that a caller
    linking it loads what it shares as well."""
    from nao_arena.kernels import parse_type, type_name

    library = cres.library
    library._reload_init.update(cres.reload_init or ())
    if py_func.__qualname__ != py_func.__name__:  # not a module attribute: not found later
        return
    args = tuple(cres.signature.args)
    names = tuple(type_name(a) for a in args)
    try:
        readable = all(parse_type(n) == a for n, a in zip(names, args, strict=True))
    except Exception:  # noqa: BLE001 - a type its text cannot rebuild: always linked
        readable = False
    if readable:
        load = LoadCallee(py_func.__module__, py_func.__name__, names, cres.fndesc.mangled_name)
        setattr(library, _TAG, load)


def shared_callees(library: Any) -> list[Any]:
    """The libraries ``library`` calls as shared callees (not linked into it)."""
    return list(getattr(library, _SHARED, ()))


def _instructions(library: Any) -> int:
    """LLVM instructions of the defined functions of ``library``'s linking module."""
    count = getattr(library, _SIZE, None)
    if count is None:
        module = library._get_module_for_linking()
        count = sum(
            1
            for fn in module.functions
            if not fn.is_declaration
            for block in fn.blocks
            for _ in block.instructions
        )
        setattr(library, _SIZE, count)
    return int(count)


def _share_large_callees(library: Any) -> None:
    """Take the shared callees out of ``library``'s linking list (see the module)."""
    linked: list[Any] = []
    shared: list[Any] = []
    for callee in library._linking_libraries:
        load = getattr(callee, _TAG, None)
        large = load is not None and _instructions(callee) >= SHARED_INSTRUCTIONS
        if large and callee is not library:
            if all(callee is not s for s in shared):  # one entry per call site
                shared.append(callee)
            library._reload_init.add(load)
        else:
            linked.append(callee)
    if shared:
        library._linking_libraries = linked
        setattr(library, _SHARED, shared)


_INSTALLED = threading.Lock()
_ORIGINAL_FINALIZE: Any = None


def install() -> None:
    """Install the rule on numba's CPU code library (once per process); it acts only
    while :data:`compiling_kernels` is set."""
    global _ORIGINAL_FINALIZE
    with _INSTALLED:
        if _ORIGINAL_FINALIZE is not None:
            return
        original = codegen.CPUCodeLibrary.finalize

        def finalize(self: Any) -> None:
            if compiling_kernels.get():
                _share_large_callees(self)
            original(self)

        _ORIGINAL_FINALIZE = original
        codegen.CPUCodeLibrary.finalize = finalize  # type: ignore[method-assign]
