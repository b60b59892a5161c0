"""The report's HTML tables: metrics, uncertainty calibration, skipped methods, identified
parameters, and the page's foot (version, date, command, input files)."""

from __future__ import annotations

import html
import math
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sideslip.evaluate import METRIC_NAMES
from sideslip.report.series import CALIBRATED_1SIGMA, CALIBRATED_2SIGMA, Calibration

esc = html.escape


def _num(value: Any) -> str:
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return f"{value:,}"
    if isinstance(value, float):
        if not math.isfinite(value):
            return "–"
        if value == 0:
            return "0"
        if abs(value) >= 1e5 or abs(value) < 1e-3:
            return f"{value:.4g}"
        return f"{value:.4g}" if abs(value) < 1 else f"{value:,.4g}"
    return esc(str(value))


def metrics_html(results: Mapping[str, Mapping[str, float]], order: Sequence[str]) -> str:
    """Every metric of every method, best in each column marked; rows in ``order``."""
    names = [k for k in METRIC_NAMES if any(k in r for r in results.values())]
    extra = sorted({k for r in results.values() for k in r} - set(METRIC_NAMES))
    cols = names + extra
    if not cols:
        return "<p>The drive has no reference columns: no metrics, nothing ranked.</p>"
    best: dict[str, float] = {}
    for c in cols:
        vals = [abs(r[c]) for r in results.values() if c in r and math.isfinite(r[c])]
        if vals:
            best[c] = min(vals)
    head = "".join(f"<th>{esc(c)}</th>" for c in cols)
    body = []
    for m in [m for m in order if m in results]:
        r = results[m]
        cells = []
        for c in cols:
            if c not in r:
                cells.append("<td>–</td>")
                continue
            mark = c in best and abs(r[c]) == best[c] and len(results) > 1
            cells.append(f"<td{' class=best' if mark else ''}>{r[c]:.3f}</td>")
        body.append(f"<tr><th>{esc(m)}</th>{''.join(cells)}</tr>")
    return f"<div class=scroll><table><tr><th>method</th>{head}</tr>{''.join(body)}</table></div>"


def calibration_html(cal: Sequence[Calibration]) -> str:
    """Share of sideslip errors inside each method's 1σ and 2σ, with a verdict per method."""
    if not cal:
        return ""
    rows = []
    for c in sorted(cal, key=lambda c: abs(c.within_2sigma - 0.954)):
        ok = c.verdict == "calibrated"
        rows.append(
            f"<tr><th>{esc(c.method)}</th><td>{c.within_1sigma:.1%}</td><td>{c.within_2sigma:.1%}</td>"
            f"<td>{c.samples:,}</td><td class={'good' if ok else 'warn'}>{esc(c.verdict)}</td></tr>"
        )
    n_ok = sum(c.verdict == "calibrated" for c in cal)
    lo1, hi1 = CALIBRATED_1SIGMA
    lo2, hi2 = CALIBRATED_2SIGMA
    return (
        f"<p><b>{n_ok} of {len(cal)}</b> methods with a σ are calibrated on this drive.  A calibrated "
        "Gaussian estimate has 68.3 % of its errors inside 1σ and 95.4 % inside 2σ; the verdict "
        f"accepts {lo1:.0%}–{hi1:.0%} and {lo2:.0%}–{hi2:.0%} (errors along a drive are correlated, "
        "so one drive's shares scatter).</p>"
        "<div class=scroll><table><tr><th>method</th><th>|e| &lt; 1σ</th><th>|e| &lt; 2σ</th>"
        f"<th>samples</th><th class=left>verdict</th></tr>{''.join(rows)}</table></div>"
    )


def skipped_html(skipped: Mapping[str, str]) -> str:
    if not skipped:
        return ""
    rows = "".join(
        f"<tr><th>{esc(m)}</th><td class=left>{esc(r)}</td></tr>" for m, r in sorted(skipped.items())
    )
    return (
        f'<div class="card"><h2>Skipped methods ({len(skipped)})</h2>'
        "<p>These could not run on this drive and vehicle file:</p>"
        f"<div class=scroll><table><tr><th>method</th><th>why</th></tr>{rows}</table></div></div>"
    )


def _flatten(prefix: str, value: Any, out: list[tuple[str, Any]]) -> None:
    if isinstance(value, Mapping):
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else str(k), v, out)
    elif isinstance(value, list | tuple) and len(value) > 6:
        nums = [v for v in value if isinstance(v, int | float) and not isinstance(v, bool)]
        if len(nums) == len(value):
            out.append((prefix, f"{len(value)} values, {min(nums):.4g} … {max(nums):.4g}"))
        else:
            out.append((prefix, f"{len(value)} entries"))
    elif isinstance(value, list | tuple):
        out.append((prefix, ", ".join(_num(v) for v in value) or "–"))
    else:
        out.append((prefix, value))


def _pair_sigmas(names: Sequence[str]) -> dict[str, str]:
    """Value name -> its 1-sigma's name: ``K`` and ``K_std``, ``slip_gain_k_s2pm`` and
    ``slip_gain_k_sigma`` (a unit suffix on the value, none on its sigma)."""
    out: dict[str, str] = {}
    for sig in names:
        for suffix in ("_sigma", "_std"):
            if not sig.endswith(suffix):
                continue
            base = sig[: -len(suffix)]
            if base in names:
                out[base] = sig
                continue
            close = [n for n in names if n.startswith(base + "_") and n != sig and not n.endswith(suffix)]
            if len(close) == 1:
                out[close[0]] = sig
    return out


SECTIONS = ("settings", "health")  # nested diagnostics shown folded under the main values


def params_html(params: Mapping[str, Any], order: Sequence[str]) -> str:
    """Identified parameters per method as a table: name, value, 1σ (from ``<name>_sigma``)."""
    blocks: list[str] = []
    for m in [m for m in order if m in params] + sorted(set(params) - set(order) - {"_skipped"}):
        p = params[m]
        if not isinstance(p, Mapping) or not p:
            continue
        main = {k: v for k, v in p.items() if k not in SECTIONS}
        rows = []
        flat: list[tuple[str, Any]] = []
        _flatten("", main, flat)
        sigmas = _pair_sigmas([k for k, _ in flat])
        values = dict(flat)
        paired = set(sigmas.values())
        for name, value in flat:
            if name in paired:
                continue
            sigma = values.get(sigmas[name]) if name in sigmas else None
            cell = f"{_num(value)}" + (f" <span class=pm>± {_num(sigma)}</span>" if sigma is not None else "")
            rows.append(f"<tr><th>{esc(name)}</th><td class=left>{cell}</td></tr>")
        extra = []
        for sec in SECTIONS:
            if isinstance(p.get(sec), Mapping) and p[sec]:
                sub: list[tuple[str, Any]] = []
                _flatten("", p[sec], sub)
                srows = "".join(f"<tr><th>{esc(k)}</th><td class=left>{_num(v)}</td></tr>" for k, v in sub)
                extra.append(f"<details><summary>{sec}</summary><table>{srows}</table></details>")
        table = f"<table>{''.join(rows)}</table>" if rows else ""
        blocks.append(
            f"<details{' open' if len(blocks) < 3 else ''}><summary><b>{esc(m)}</b></summary>"
            f"<div class=scroll>{table}</div>{''.join(extra)}</details>"
        )
    if not blocks:
        return ""
    return (
        '<div class="card"><h2>Identified parameters and diagnostics</h2>'
        "<p>Values as each method identified them (± its 1σ where it gives one); names carry "
        "their units.</p>" + "".join(blocks) + "</div>"
    )


def footer_html(command: str | None, inputs: Sequence[str | Path]) -> str:
    """Version, UTC date, the command that made the report and its input files."""
    from sideslip import __version__

    when = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    files = []
    for f in inputs:
        p = Path(f)
        size = f" ({p.stat().st_size / 1e6:.1f} MB)" if p.is_file() else ""
        files.append(f"<li><code>{esc(str(f))}</code>{esc(size)}</li>")
    cmd = f"<p>Command: <code>{esc(command)}</code></p>" if command else ""
    listed = f"<p>Input files:</p><ul>{''.join(files)}</ul>" if files else ""
    return f'<footer><p>sideslip {esc(__version__)} · generated {when}</p>{cmd}{listed}</footer>'
