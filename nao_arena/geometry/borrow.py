"""Borrowed array views for the compiled kernels' hot loops.

numba counts references to every array it passes around: each array argument
of a compiled function, and of every compiled call in a loop, costs an
atomic increment and decrement per call. In the candidate tests (thousands
per selection, each touching about ten arrays) those atomics took a quarter
of the selection time.

:func:`borrowed` returns the same array (same data, shape, strides) without
its memory-management handle, so the runtime has nothing to count: the
increments and decrements on it become a null test. The view does not keep
the memory alive. Rules, which the kernels follow:

- borrow only a function's own array arguments (the caller keeps them alive
  for the whole call), at the top of the function;
- never return, store or yield a borrowed view; pass it down only to calls
  that return before the function does.

Scratch arrays a function allocates for its hot loop are therefore allocated
by a thin wrapper and passed to the loop as arguments.

:func:`borrowed_fields` does the same for every array of a named bundle (see
:mod:`nao_arena.geometry._kernel.bundles`; its other fields are numbers): the bundle
comes back with each array field borrowed and its numbers as they were, under the
same rules.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["borrowed", "borrowed_fields"]


if TYPE_CHECKING:
    from typing import TypeVar

    import numpy as np

    _ArrayT = TypeVar("_ArrayT", bound=np.ndarray)
    _BundleT = TypeVar("_BundleT", bound=tuple)

    # numba's stubs type an intrinsic's call with its typing function's signature
    # (typingctx first) and as never returning; compiled code calls it like this:

    def borrowed(arr: _ArrayT, /) -> _ArrayT:
        """``arr`` (a numba array) as a view without reference counting (see the module)."""
        ...

    def borrowed_fields(bundle: _BundleT, /) -> _BundleT:
        """``bundle`` (a named tuple) with each array field borrowed (see the module)."""
        ...

else:

    def _borrow(context, builder, array_type, value):
        """The codegen of a borrowed view of ``value`` (an array of ``array_type``)."""
        src = context.make_array(array_type)(context, builder, value=value)
        view = context.make_array(array_type)(context, builder)
        for field in ("nitems", "itemsize", "data", "shape", "strides"):
            setattr(view, field, getattr(src, field))
        view.meminfo = cgutils.get_null_value(view.meminfo.type)
        view.parent = cgutils.get_null_value(view.parent.type)
        return view._getvalue()

    @intrinsic
    def borrowed(typingctx, arr):
        """``arr`` (a numba array) as a view without reference counting (see the module)."""
        if not isinstance(arr, types.Array):
            return None
        sig = arr(arr)

        def codegen(context, builder, sig, args):
            return _borrow(context, builder, sig.args[0], args[0])

        return sig, codegen

    @intrinsic
    def borrowed_fields(typingctx, bundle):
        """``bundle`` (a named tuple) with each array field borrowed (see the module).
        Its other fields must be numbers or booleans: a field that numba counts
        references to (a nested tuple of arrays, a typed dict) would be handed back
        without its reference."""
        if not isinstance(bundle, types.BaseNamedTuple) or not all(
            isinstance(t, (types.Array, types.Number, types.Boolean)) for t in bundle
        ):
            return None
        sig = bundle(bundle)

        def codegen(context, builder, sig, args):
            out = args[0]
            for i, field_type in enumerate(sig.args[0]):
                if isinstance(field_type, types.Array):
                    value = builder.extract_value(out, i)
                    out = builder.insert_value(out, _borrow(context, builder, field_type, value), i)
            return out

        return sig, codegen
