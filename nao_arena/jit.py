"""The two decorators every compiled function of the package is made with.

Both compile in nopython mode on first call with new argument types and keep the
machine code in numba's on-disk cache (``cache=True``; see :mod:`nao_arena.kernels`
for compiling ahead of time). Neither builds the C-callable wrapper that only
first-class function values and ``cfunc`` need.

- :func:`kernel`: a function that Python code calls (the arena, the agents, the
  statistics call it with numpy arrays). numba builds its Python wrapper: the code
  that unboxes each argument and boxes the result.
- :func:`inner_kernel`: a function that only other compiled functions call. It has no
  Python wrapper. That wrapper is about a fifth of what compiling costs: it is built
  for every function and optimised and turned into machine code again in every
  caller whose code links the function's. A call from Python (a test, a notebook) is
  still answered: it goes to a twin of the function, compiled with a Python wrapper
  in this process only and never cached, so the two versions never meet in the
  cache. No production path calls an inner kernel from Python (a test runs every
  built-in agent on every shipped map and checks that no twin was made).

Both make a :class:`Kernel` dispatcher (or its :class:`InnerKernel`), under which a
large callee's code is shared by its callers rather than copied into each of them
(:mod:`nao_arena.shared_code`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any, TypeVar, overload

from numba import config, njit
from numba.core.registry import CPUDispatcher

import nao_arena.shared_code as shared_code

__all__ = ["InnerKernel", "Kernel", "inner_kernel", "kernel", "twins_made"]

LOG = logging.getLogger("nao_arena.kernels")

F = TypeVar("F", bound=Callable[..., Any])

_TARGET_OPTIONS = {"no_cfunc_wrapper": True}
"""numba's options of every compiled function of the package (see the module); every
one is cached (``cache=True``)."""

_TWINS: dict[str, Any] = {}

_njit: Any = njit  # its stubs know no options passed as a mapping


def twins_made() -> list[str]:
    """The inner kernels that Python code has called in this process (each compiled a
    twin with a Python wrapper), by qualified name."""
    return sorted(_TWINS)


shared_code.install()


class Kernel(CPUDispatcher):
    """The numba dispatcher of every compiled function of the package (:func:`kernel`).
    While it compiles or loads a version, its large callees are shared rather than
    copied into it; it marks the code of each version as the package's (which its own
    callers may share) and keeps it in :class:`~nao_arena.shared_code.KernelCache`, whose
    entries with a shared callee that cannot be loaded are misses
    (:mod:`nao_arena.shared_code`)."""

    def compile(self, sig: Any) -> Any:
        token = shared_code.compiling_kernels.set(True)
        try:
            return super().compile(sig)
        finally:
            shared_code.compiling_kernels.reset(token)

    def enable_caching(self) -> None:
        self._cache = shared_code.KernelCache(self.py_func)

    def add_overload(self, cres: Any) -> None:
        super().add_overload(cres)
        if not cres.objectmode:
            shared_code.tag(cres, self.py_func)


class InnerKernel(Kernel):
    """A numba dispatcher compiled without a Python wrapper (:func:`inner_kernel`)."""

    twin_options: dict[str, Any]

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        # the compiled entry point has no Python wrapper: calling it would crash
        name = f"{self.py_func.__module__}.{self.py_func.__qualname__}"
        twin = _TWINS.get(name)
        if twin is None:
            LOG.debug("%s called from Python: compiling a twin with a Python wrapper", name)
            twin = _TWINS[name] = _njit(**self.twin_options)(self.py_func)
        return twin(*args, **kwargs)


def _cached_dispatcher(cls: type[Kernel], py_func: Any, targetoptions: dict[str, Any]) -> Any:
    """A cached dispatcher of class ``cls`` (as ``njit(cache=True, ...)`` makes one)."""
    dispatcher = cls(py_func=py_func, targetoptions=targetoptions)
    dispatcher.enable_caching()
    return dispatcher


@overload
def kernel(func: F) -> F: ...
@overload
def kernel(**options: Any) -> Callable[[F], F]: ...
def kernel(func: Any = None, **options: Any) -> Any:
    """Compile ``func`` (see the module), called from Python; ``options``: numba's
    (``error_model``, ...). Use as ``@kernel`` or ``@kernel(error_model="numpy")``."""

    def decorate(py_func: Any) -> Any:
        # NUMBA_DISABLE_JIT=1: the plain Python function, as numba's njit gives
        if getattr(config, "DISABLE_JIT", False):
            return py_func
        return _cached_dispatcher(Kernel, py_func, {"nopython": True, **_TARGET_OPTIONS, **options})

    return decorate if func is None else decorate(func)


@overload
def inner_kernel(func: F) -> F: ...
@overload
def inner_kernel(**options: Any) -> Callable[[F], F]: ...
def inner_kernel(func: Any = None, **options: Any) -> Any:
    """Compile ``func`` (see the module), called only by compiled functions;
    ``options``: numba's (``error_model``, ...)."""

    def decorate(py_func: Any) -> Any:
        # NUMBA_DISABLE_JIT=1: the plain Python function, as numba's njit gives
        if getattr(config, "DISABLE_JIT", False):
            return py_func
        targetoptions = {
            "nopython": True,
            **_TARGET_OPTIONS,
            "no_cpython_wrapper": True,
            **options,
        }
        dispatcher = _cached_dispatcher(InnerKernel, py_func, targetoptions)
        dispatcher.twin_options = dict(options)
        return dispatcher

    return decorate if func is None else decorate(func)
