"""Every method on tyres that build their force over a relaxation length, which no method models.

Real tyres build their lateral force over about one relaxation length of travel (0.5-1.5 m for
passenger-car tyres, Pacejka 2012 sec. 7.2); the simulator's tyres had answered their slip at
once, and so do the axle relations of every model-based method here.  Every own scenario of
the comparison (seed 0, its own receiver; the CommonRoad scenarios run CommonRoad's tyres)
with the truth's tyres lagging over 0 / 0.5 / 1 m (``simulate(..., tyre_relaxation_m=...)``),
the right vehicle file, every registered method.  Per method: the mean beta RMSE (deg, rows
faster than 5 m/s) over the scenarios it runs on, at each relaxation length; for ``fused`` and
``fused_filter`` the lowest 2-sigma share, and for ``fused`` what its installation and timing
checks moved (a check that takes the tyres' lag for a misplaced sensor or a late receiver
would show here).  Writes ``benchmarks/results/tyre_relaxation.md``.
Run: ``.venv/bin/python benchmarks/tyre_relaxation.py``.
"""

from __future__ import annotations

import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from compare_methods import SCENARIOS, two_sigma_share
from results_file import write_result

from sideslip.evaluate import metrics
from sideslip.methods.registry import all_methods, run_method, why_not
from sideslip.simulate import simulate
from sideslip.vehicle import load_vehicle

OUT = Path(__file__).parent / "results" / "tyre_relaxation.md"
RELAXATION_M = (0.0, 0.5, 1.0)
OWN = tuple(s for s in SCENARIOS if not s.startswith("cr_"))


def _moved(params: dict) -> list[str]:
    """What fused's checks moved: the antenna, the IMU, the box, the Doppler's timing."""
    out = []
    for key, label in (("gnss_lever_x_applied_m", "antenna"), ("imu_lever_x_applied_m", "IMU"),
                       ("box_x_applied_m", "box")):  # fmt: skip
        if params.get(key):
            out.append(f"{label} {float(params[key]):+.2f} m")
    if params.get("gnss_doppler_latency_s"):
        out.append(f"Doppler {float(params['gnss_doppler_latency_s']) * 1000:.0f} ms")
    return out


def _cell(task: tuple[str, float]) -> tuple[str, float, dict[str, float], dict[str, float], list[str]]:
    """One scenario at one relaxation length: beta RMSE and 2-sigma share per method, and what
    fused's checks moved."""
    name, relaxation = task
    drive = simulate(name, seed=0, tyre_relaxation_m=relaxation)
    vehicle = load_vehicle(drive.meta["vehicle"])
    beta: dict[str, float] = {}
    share: dict[str, float] = {}
    moved: list[str] = []
    for method_name, method in all_methods().items():
        if why_not(method, drive, vehicle) is not None:
            continue
        est = run_method(method, drive, vehicle)
        m = metrics(drive, est.series)
        if "beta_rmse_deg" in m:
            beta[method_name] = m["beta_rmse_deg"]
        if method_name in ("fused", "fused_filter"):
            share[method_name] = two_sigma_share(drive, est) or 0.0
        if method_name == "fused":
            moved = _moved(dict(est.params))
    return name, relaxation, beta, share, moved


def main() -> None:
    start = time.perf_counter()
    tasks = [(name, r) for r in RELAXATION_M for name in OWN]
    with ProcessPoolExecutor(max_workers=2) as pool:
        cells = list(pool.map(_cell, tasks))
    methods = [m for m in all_methods() if any(m in c[2] for c in cells)]
    head = " | ".join(f"{r:g} m" for r in RELAXATION_M)
    body = [
        f"| method | scenarios | mean beta RMSE at relaxation {head} |",
        "|---|---:|" + "---:|" * len(RELAXATION_M),
    ]
    for method in methods:
        # the scenarios where the method ran at every relaxation length
        names = [n for n in OWN if all(method in c[2] for c in cells if c[0] == n)]
        if not names:
            continue
        means = []
        for r in RELAXATION_M:
            values = [c[2][method] for c in cells if c[1] == r and c[0] in names]
            means.append(sum(values) / len(values))
        body.append(f"| {method} | {len(names)} | " + " | ".join(f"{v:.3f}" for v in means) + " |")
    body += ["", "Lowest 2-sigma share over the scenarios:", ""]
    for method in ("fused", "fused_filter"):
        lows = [min(c[3].get(method, 1.0) for c in cells if c[1] == r) for r in RELAXATION_M]
        body.append(f"- {method}: " + ", ".join(f"{v:.2f} at {r:g} m" for v, r in zip(lows, RELAXATION_M, strict=True)))
    body += ["", "What fused's installation and timing checks moved (right installation, on time):", ""]
    for name, r, _, _, moved in cells:
        if moved:
            body.append(f"- {name} at {r:g} m: {', '.join(moved)}")
    if not any(c[4] for c in cells):
        body.append("- nothing, in any scenario at any relaxation length")
    body += ["", "fused per scenario (beta RMSE deg at 0 / 0.5 / 1 m):", ""]
    for name in OWN:
        row = [c[2].get("fused", float("nan")) for r in RELAXATION_M for c in cells if c[0] == name and c[1] == r]
        body.append(f"- {name}: " + " / ".join(f"{v:.3f}" for v in row))
    body.append("")
    intro = __doc__.split("\n\n")[1].replace("\n", " ").split(" Writes ")[0]
    write_result(OUT, "Tyres that build their force over a relaxation length", "benchmarks/tyre_relaxation.py",
                 time.perf_counter() - start, intro, body)  # fmt: skip


if __name__ == "__main__":
    main()
