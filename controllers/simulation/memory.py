"""The memory a run of a given length needs, checked against the memory available before anything is allocated.

A run of ``duration`` s at the controller period ``Tc`` has ``N = round(duration/Tc)`` samples, and every signal a
job keeps over the whole run (the reference, the recorded velocities and torques of a closed-loop run, its
measurement noise, the arrays of an identification run) is ``8*N`` bytes (float64). :func:`check_run_memory`
multiplies that by the number of such signals the job holds at once and refuses a job that does not fit into the
memory the operating system reports available (:func:`available_memory`), with a
:class:`plant.errors.ParameterError` that says how many samples the duration is, about how much memory they need
and the longest duration that fits: instead of a ``MemoryError`` from inside numpy after seconds of work, or a
machine that swaps. The entries that allocate by duration call it first: :class:`controllers.CompareOptions`
(so :func:`controllers.compare`, the zoo's and the sweep's comparisons), :func:`controllers.run_closed_loop`,
:func:`controllers.experiments.zoo.run_zoo` and :func:`controllers.experiments.sweep.run_sweep` (their worker
processes at once).

The signal counts below are upper bounds of the peak resident memory measured with ``ru_maxrss`` on the
``paper`` preset (numpy 2; the slope between 200 s and 600 s runs): ``compare`` with all eight modes
372 bytes per sample (the estimate ``8*(SHARED_SIGNALS + 8*MODE_SIGNALS)`` is 416), its preparation with the
identification run of ``fixed`` 306 bytes per sample (``8*PREPARATION_SIGNALS`` is 320).
"""

from __future__ import annotations

import math
import os
import time

from plant.errors import ParameterError, check_positive

__all__ = ["SHARED_SIGNALS", "MODE_SIGNALS", "PREPARATION_SIGNALS", "available_memory", "run_bytes",
           "check_run_memory"]

#: Signals of N samples shared by the runs of a job: the reference (time, velocity, acceleration) and the
#: metrics' temporaries.
SHARED_SIGNALS = 4

#: Signals of N samples one recorded closed-loop run holds: the five recorded signals (velocity, measured
#: velocity, torque, compensation torque, friction), its measurement noise and (a fraction of one) the
#: estimator's parameter history.
MODE_SIGNALS = 6

#: Signals of N samples the preparation of a comparison holds at its peak: the identification run behind
#: ``fixed`` and the adaptive start (open-loop torque and response, the noisy measurement, the sliding fit's
#: filtered signals and regressors).
PREPARATION_SIGNALS = 40

_BYTES = 8  # float64


#: How long (s) a reading of :func:`available_memory` is reused: reading ``/proc/meminfo`` costs more than the
#: Python part of a short run's other checks, and a run of a few seconds starts several times a second.
READING_LIFETIME = 1.0
_reading: list = [-math.inf, None]  # [time.monotonic() of the reading, its result]


def available_memory() -> tuple[int, str] | None:
    """Memory (bytes) a new allocation may use now, and where the number comes from; None when unknown.

    A reading is reused for :data:`READING_LIFETIME` s (kept in memory only: the last one of this process).

    In this order: ``MemAvailable`` of ``/proc/meminfo`` (Linux: free memory plus the page cache the kernel
    can drop), lowered to the free part of a cgroup v2 limit (``/sys/fs/cgroup/memory.max`` minus
    ``memory.current``, a container's limit) when that is smaller; else ``os.sysconf("SC_AVPHYS_PAGES")`` times
    the page size (free physical memory); else ``os.sysconf("SC_PHYS_PAGES")`` (all physical memory).

    Returns
    -------
    (int, str) or None
        Bytes and the end of a sentence ``"<bytes> of memory ..."`` naming the source (e.g. ``"are available"``),
        or None on a system that reports none of them (then no run is refused).
    """
    now = time.monotonic()
    if now - _reading[0] < READING_LIFETIME:
        return _reading[1]
    found = _read_available()
    _reading[0], _reading[1] = now, found
    return found


def _read_available() -> tuple[int, str] | None:
    """:func:`available_memory` read now from the system (no reuse)."""
    avail = _meminfo_available()
    if avail is not None:
        limit = _cgroup_free()
        if limit is not None and limit < avail:
            return limit, "are free under this process's cgroup memory limit"
        return avail, "are available"
    for name, what in (("SC_AVPHYS_PAGES", "are free"), ("SC_PHYS_PAGES", "is all this machine has")):
        try:
            pages, size = os.sysconf(name), os.sysconf("SC_PAGE_SIZE")
        except (AttributeError, ValueError, OSError):
            continue
        if pages > 0 and size > 0:
            return int(pages) * int(size), what
    return None


def _read(path: str, size: int) -> bytes:
    """The first ``size`` bytes of the file ``path`` (one ``read``: no text layer, the kernel's pseudo-files are read
    fresh at each call)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        return os.read(fd, size)
    finally:
        os.close(fd)


def _meminfo_available() -> int | None:
    try:
        data = b"\n" + _read("/proc/meminfo", 1 << 14)  # every line after a newline, the first one too
        at = data.index(b"\nMemAvailable:") + 14
        return int(data[at:data.index(b"\n", at)].split()[0]) * 1024
    except (OSError, ValueError, IndexError):
        return None


def _cgroup_free() -> int | None:
    try:
        limit = _read("/sys/fs/cgroup/memory.max", 64).strip()
        if limit == b"max":
            return None
        used = int(_read("/sys/fs/cgroup/memory.current", 64).strip())
        return max(int(limit) - used, 0)
    except (OSError, ValueError):
        return None


def run_bytes(n_samples: int, signals: int, processes: int = 1) -> int:
    """Bytes of ``signals`` float64 signals of ``n_samples`` samples in each of ``processes`` processes."""
    return _BYTES * int(n_samples) * int(signals) * int(processes)


def check_run_memory(duration: float, Tc: float, *, signals: int, what: str = "duration", detail: str = "",
                     processes: int = 1) -> int:
    """Refuse a job whose duration-long signals do not fit into the memory available; the number of samples.

    Parameters
    ----------
    duration : float
        Run length (s), > 0.
    Tc : float
        Sample period of the signals (s), > 0.
    signals : int
        Signals of ``round(duration/Tc)`` float64 samples the job holds at its peak in each process (e.g.
        ``SHARED_SIGNALS + MODE_SIGNALS*n_modes`` for a comparison of ``n_modes`` recorded runs).
    what : str, keyword-only
        Name of the duration in the message (the argument or option the user gave).
    detail : str, keyword-only
        What the signals are for, in the message (e.g. ``"8 modes"``).
    processes : int, keyword-only
        Processes holding such signals at the same time (workers of a pool), >= 1.

    Returns
    -------
    int
        The number of samples, ``round(duration/Tc)``.

    Raises
    ------
    ParameterError
        ``duration`` or ``Tc`` not > 0, or the job needs more than :func:`available_memory`. The message gives
        the samples, the memory needed, the memory available and the longest duration that fits, e.g.
        ``duration = 1e+09 s is 1e12 samples at 1 kHz (Tc = 0.001 s): about 416 TB for 8 modes, but 18.9 GB of
        memory are available: at most 45,432 s fit``.
    """
    duration = check_positive(what, duration)
    Tc = check_positive("Tc", Tc)
    n = int(round(duration / Tc))
    found = available_memory()
    if found is None:
        return n
    avail, source = found
    need = run_bytes(n, signals, processes)
    if need <= avail:
        return n
    n_max = avail // run_bytes(1, signals, processes)
    fits = (f"at most {_seconds(n_max * Tc)} fit" if n_max >= 2 else "not even two samples fit")
    rate = 1.0 / Tc
    rate_text = f"{rate / 1e3:g} kHz" if rate >= 1e3 else f"{rate:g} Hz"
    per = f" in each of {processes} processes" if processes > 1 else ""
    raise ParameterError(f"{what} = {duration:g} s is {_count(n)} samples at {rate_text} (Tc = {Tc:g} s): about "
                         f"{_size(need)} for {detail or f'{signals} signals'}{per}, but {_size(avail)} of memory "
                         f"{source}: {fits}")


def _count(n: int) -> str:
    """``n`` with thousands separators, or as ``1.23e12`` from a million on."""
    if n < 1_000_000:
        return f"{n:,}"
    mantissa, exponent = f"{n:.2e}".split("e")
    return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"


def _seconds(s: float) -> str:
    """A duration in s (whole seconds with separators from 10 s on), with hours or days when long."""
    text = f"{math.floor(s):,} s" if s >= 10 else f"{s:.3g} s"
    if s >= 2 * 86400:
        text += f" ({s / 86400:.3g} days)"
    elif s >= 2 * 3600:
        text += f" ({s / 3600:.3g} h)"
    return text


def _size(b: float) -> str:
    """Bytes in decimal units (kB = 1000 B), three significant digits."""
    for unit, scale in (("EB", 1e18), ("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if b >= scale:
            return f"{b / scale:.3g} {unit}"
    return f"{int(b)} B"
