"""The machine a bench ran on, for its first line: the CPU model and the vector extensions the
peers' JIT compilers may use (Mitsuba's LLVM backend uses the host's full width)."""
from __future__ import annotations

EXTENSIONS = ("sse4_2", "avx", "avx2", "fma", "avx512f", "avx512bw", "avx512vl")


def cpu_line() -> str:
    """`CPU: <model> (<extensions>), <n> logical cores`; `CPU: unknown` without /proc/cpuinfo."""
    try:
        with open("/proc/cpuinfo") as f:
            info = f.read()
    except OSError:
        return "CPU: unknown"
    lines = info.splitlines()
    model = next((ln.split(":", 1)[1].strip() for ln in lines if ln.startswith("model name")), "?")
    flags = next((ln.split(":", 1)[1].split() for ln in lines if ln.startswith("flags")), [])
    cores = sum(1 for ln in lines if ln.startswith("processor"))
    ext = [f for f in EXTENSIONS if f in flags]
    return f"CPU: {model} ({', '.join(ext) or 'no SIMD extension listed'}), {cores} logical cores"
