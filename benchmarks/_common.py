"""Shared by the benchmark scripts: BLAS thread limits and the machine description line."""
import os
import platform
import time

THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def limit_threads(n: int) -> None:
    """Set the BLAS thread count; call before numpy is imported."""
    for var in THREAD_VARIABLES:
        os.environ[var] = str(n)


def no_wave_cache() -> None:
    """Switch railfem's in-memory wave cache off (before railfem solves anything), so that
    repeated timings of the same solve measure the solve, not a cache hit."""
    os.environ["RAILFEM_WAVE_CACHE_MB"] = "0"


def machine_lines(threads: int) -> list[str]:
    """When and where the benchmark ran: date, host, CPUs, versions, BLAS threads, load."""
    import numpy as np
    import scipy

    lines = [f"  {time.strftime('%Y-%m-%d %H:%M:%S')}, {platform.node()}, {os.cpu_count()} CPUs, "
             f"python {platform.python_version()}, numpy {np.__version__}, "
             f"scipy {scipy.__version__}, BLAS threads {threads}"]
    try:
        load = os.getloadavg()
        lines.append(f"  load average at start {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    except OSError:
        pass
    return lines
