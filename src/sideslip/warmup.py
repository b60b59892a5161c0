"""Compile the numba kernels ahead of the first estimate, in parallel processes.

Every hot loop of the toolkit is a numba kernel compiled on first use and cached beside its
source (``cache=True``).  On a fresh install the first ``fused`` estimate spends about 55 s
compiling, the simulator about 14 s, the ``fg_batch`` and ``ekf_wss_sas`` families about
21 s each (one process, 2-core machine, measured 2026-12-03; :data:`FAMILIES`); later runs
load the cache in well under a second.  Two processes that start cold each compile what they
touch, so a test run on two workers, or a fleet run on a fresh cluster, pays for the same
kernels twice.  :func:`warm_kernels` runs every registered method once on a short simulated
drive, the methods split over ``jobs`` processes so that no kernel family is compiled twice,
and leaves a warm cache behind.  With a warm cache it costs a few seconds.

Run: ``python -m sideslip.warmup [--jobs N]`` (the install of ``make`` does, before ``make demo``
and ``make test``; ``make warm`` again after a source change).
"""

from __future__ import annotations

import argparse
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor

# methods that share kernels, with the seconds their kernels take to compile on a cold cache
# after the simulator's (2 cores, 2026-12-03): a family stays in one process, so that nothing
# is compiled twice, and the families are dealt longest first to the least loaded process
FAMILIES: tuple[tuple[tuple[str, ...], float], ...] = (
    (("fused", "fused_filter"), 53.0),
    (("fg_batch", "fg_lag", "kf_linear"), 22.0),
    (("ekf_wss_sas", "ekf_wss_sas_imu"), 21.0),
    (("mkf", "mkf_adaptive"), 13.0),
    (("obs_bicycle", "obs_kinematic", "obs_modified", "obs_modified_nocomp"), 6.0),
    (("doppler_slip", "doppler_slip_noroll", "roll_dfc", "roll_index"), 6.0),
    (("kkf",), 6.0),
    (("kinematic_integration",), 2.0),
)
OTHER_METHOD_S = 2.0  # a method in no family above
WARM_SCENARIO = "demo"
WARM_DURATION_S = 30.0


def method_groups(jobs: int) -> list[list[str]]:
    """Every registered method in at most ``jobs`` groups of whole families (:data:`FAMILIES`),
    balanced by their compile seconds (longest family first to the least loaded group)."""
    from sideslip.methods.registry import all_methods

    names = set(all_methods())
    families = [([n for n in fam if n in names], s) for fam, s in FAMILIES]
    known = {n for fam, _ in FAMILIES for n in fam}
    families += [([n], OTHER_METHOD_S) for n in sorted(names - known)]
    families = sorted((f for f in families if f[0]), key=lambda f: -f[1])
    groups: list[list[str]] = [[] for _ in range(max(1, jobs))]
    load = [0.0] * len(groups)
    for fam, seconds in families:
        i = load.index(min(load))
        groups[i].extend(fam)
        load[i] += seconds
    return [g for g in groups if g]


def warm_group(methods: list[str]) -> float:
    """Run ``methods`` once on a short simulated drive (compiling and caching what they use);
    returns the seconds it took.  A method the drive cannot serve is skipped."""
    from sideslip.evaluate import metrics
    from sideslip.methods.registry import get_method, run_method, why_not
    from sideslip.simulate import simulate
    from sideslip.vehicle import load_vehicle

    start = time.perf_counter()
    drive = simulate(WARM_SCENARIO, seed=0, duration_s=WARM_DURATION_S)
    vehicle = load_vehicle(drive.meta["vehicle"])
    for name in methods:
        method = get_method(name)
        if why_not(method, drive, vehicle) is None:
            metrics(drive, run_method(method, drive, vehicle).series)
    return time.perf_counter() - start


def warm_kernels(jobs: int = 2) -> list[tuple[list[str], float]]:
    """Compile every method's kernels in ``jobs`` fresh processes; returns each group with its
    seconds.  The processes are spawned (not forked), so each starts as a user's would."""
    groups = method_groups(jobs)
    if len(groups) == 1:
        return [(groups[0], warm_group(groups[0]))]
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=len(groups), mp_context=ctx) as pool:
        seconds = list(pool.map(warm_group, groups))
    return list(zip(groups, seconds, strict=True))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sideslip.warmup", description=__doc__.split("\n")[0])
    parser.add_argument("--jobs", type=int, default=2, help="processes to compile in (default 2)")
    args = parser.parse_args(argv)
    if args.jobs < 1:
        parser.error(f"--jobs {args.jobs}: expected an integer >= 1")
    start = time.perf_counter()
    for group, seconds in warm_kernels(args.jobs):
        print(f"warm-up: {', '.join(group)}: {seconds:.1f} s")
    print(f"warm-up: numba kernels compiled and cached in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
