"""``python -m ares.jit``: compile (or load) every numba kernel once for this machine -- the
Makefile's install step -- and measure the libraries' memory for ``ares validate``'s estimate.

A top-level entry: it imports the kernel modules (``ares.analysis.kernels``, ``ares.sim.fused``);
nothing imports it. The compile helpers themselves are ``ares.analysis.kernels.jit``.
"""

from __future__ import annotations

import os


def warm_all() -> float:
    """Compile (or load) every kernel with the argument types the commands use; returns
    the seconds it took. ``python -m ares.jit`` runs it (the Makefile's install step)."""
    import time

    import numpy as np

    t0 = time.perf_counter()
    from ares.analysis.kernels import highpass as highpass_kernel
    from ares.analysis.kernels import hmm
    from ares.analysis.kernels import int_fold
    from ares.analysis.kernels import lowpass
    from ares.analysis.kernels import masked_fold
    from ares.analysis.kernels import pair as pair_kernel
    from ares.sim import fused

    fused.warm()
    hmm.warm()
    lowpass.warm()
    highpass_kernel.warm()
    int_fold.warm()
    for dtype in (np.uint8, np.uint16):
        masked_fold.warm(dtype)
        pair_kernel.pair_pass(np.zeros((4, 4), dtype), np.zeros((4, 4), dtype), None)
    return time.perf_counter() - t0


if __name__ == "__main__":  # python -m ares.jit: the install step of the Makefile
    if os.environ.get("ARES_NO_NUMBA"):
        print("ARES_NO_NUMBA is set: nothing to compile")
    else:
        print(f"numba kernels compiled or loaded in {warm_all():.1f} s")
    from ares.memory_base import record  # the libraries' memory, for the estimate of ares validate

    base = record()
    print("libraries' memory not measured here" if base is None else
          f"libraries' memory measured: {base / 2**20:.0f} MiB (the base of the memory estimate)")
