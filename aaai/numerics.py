"""Matrix products that give the same bits on every CPU: MKL's compatible code path.

torch's CPU build does its float32 matrix products with Intel's MKL, which picks its kernels by the
CPU it finds (AVX-512 on one machine, AVX2 or a vendor's own path on another). Their results differ
in the last bits, and training turns last bits into other weights: the same DAgger config, seed and
data gave other weights from its first refit on two machines, and another student (docs:
Determinism, "Training on another CPU"). MKL's Conditional Numerical Reproducibility mode
``COMPATIBLE`` is meant to run one set of kernels on every x86-64 CPU; measured, the same config and
seed train the same weights on CPUs of one maker, and other weights on an AMD EPYC and an Intel Xeon
(docs: Determinism, "Training on another CPU").

The ``aaai`` command asks for it before anything is computed (``portable_maths``, called when the
command's package is imported), and its worker processes inherit it. A user's own ``MKL_CBWR`` is
kept: ``MKL_CBWR=`` (empty) gives MKL's own choice by the CPU back. MKL reads the variable once, at its first
product, so in a Python session of your own it must be set before torch computes anything:

    import os
    os.environ.setdefault("MKL_CBWR", "COMPATIBLE")
"""

from __future__ import annotations

import os

MKL_VARIABLE = "MKL_CBWR"
PORTABLE = "COMPATIBLE"
MKL_DEFAULT = "unset"  # MKL's own choice of kernels by the CPU (not the same as MKL_CBWR=AUTO)


def portable_maths() -> str:
    """Sets ``MKL_CBWR=COMPATIBLE`` unless ``MKL_CBWR`` is set already; returns the setting in force."""
    return os.environ.setdefault(MKL_VARIABLE, PORTABLE)


def mkl_setting() -> str:
    """The ``MKL_CBWR`` this process runs with (``unset`` when unset or empty), as a run folder records it."""
    return os.environ.get(MKL_VARIABLE) or MKL_DEFAULT
