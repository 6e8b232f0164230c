"""The precompiled kernels shipped with the package: one zip per Python version, numba
version and platform, made and read by :mod:`nao_arena.precompiled`. No code."""
