"""Self-contained HTML report: one offline file (plotly.js embedded once), readable on a phone.

Sections: summary, metrics, uncertainty calibration, sideslip (with each method's 1σ band and
an error histogram per method), roll and bank, heading, the trajectory on a map-like ENU plot,
speed with GNSS availability, skipped methods, identified parameters, and a foot with version,
date, command and input files.  Plotted series are decimated (min/max per bucket, so a 1 h
drive stays a few MB); the metrics use every row.
"""

from __future__ import annotations

import html
import json
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import plotly.io as pio
from plotly.offline import get_plotlyjs

from sideslip.drive import COLUMNS, Drive, _atomic_write
from sideslip.estimate import SKIPPED_KEY
from sideslip.evaluate import SPEED_GATE, evaluate_all
from sideslip.report import figures as fg
from sideslip.report.series import SHOWN, Ranking, calibration, gnss_outages, rank
from sideslip.report.tables import calibration_html, footer_html, metrics_html, params_html, skipped_html

Series = Mapping[str, Mapping[str, Any]]
esc = html.escape

CSS = """
*{box-sizing:border-box}
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:0 auto;max-width:1200px;
color:#222;padding:0.5em 1em;line-height:1.4}
h1{margin:0.3em 0 0.1em;font-size:1.6em} h2{font-size:1.2em;margin:0.4em 0} .sub{color:#666;margin-top:0}
.scroll{overflow-x:auto;max-width:100%}
table{border-collapse:collapse;font-size:13px;margin:0.6em 0}
th,td{border:1px solid #ddd;padding:3px 7px;text-align:right;white-space:nowrap}
th{background:#f5f5f5} tr th:first-child{text-align:left} td.left{text-align:left;white-space:normal}
th.left{text-align:left} td.best{background:#d8f0d8;font-weight:600}
td.good{background:#e3f4e3;text-align:left}
td.warn{background:#fdf0d5;text-align:left} .pm{color:#666}
details{margin:0.4em 0} summary{cursor:pointer}
.card{border:1px solid #e5e5e5;border-radius:8px;padding:0.4em 1em;margin:1em 0;background:#fff}
.note{background:#fff7e0;border-left:4px solid #f0b400;padding:0.5em 0.8em}
.plot{width:100%;min-height:300px;margin:0.5em 0}
footer{color:#666;font-size:12px;border-top:1px solid #ddd;margin-top:2em;padding-top:0.5em}
code{font-size:12px;word-break:break-all}
#js-errors{color:#b00;white-space:pre-wrap}
@media (max-width:640px){body{padding:0.3em 0.5em} h1{font-size:1.25em} table{font-size:12px}
.card{padding:0.3em 0.6em} .plot{min-height:260px}}
"""

# Draw every figure; record failures in the page so a headless browser (and a reader) sees them.
SCRIPT = """
(function(){
  var errs=document.getElementById('js-errors');
  function fail(msg){errs.textContent+=msg+'\\n';document.body.setAttribute('data-js-errors','1');}
  window.addEventListener('error',function(e){fail('error: '+e.message);});
  var figs=JSON.parse(document.getElementById('figure-data').textContent);
  var done=0;
  figs.forEach(function(f){
    try{Plotly.newPlot(f.id,f.fig.data,f.fig.layout,{responsive:true,displaylogo:false})
      .then(function(){done+=1;document.body.setAttribute('data-plots-rendered',String(done));
        var d=document.documentElement;  // for tests on narrow screens: no sideways scrolling
        document.body.setAttribute('data-overflow-x',String(Math.max(0,d.scrollWidth-d.clientWidth)));},
            function(e){fail('plot '+f.id+': '+e);});}
    catch(e){fail('plot '+f.id+': '+e);}
  });
  document.body.setAttribute('data-plots-expected',String(figs.length));
})();
"""


def _ranking_note(ranking: Ranking, what: str) -> str:
    if ranking.by is None:
        shown = ", ".join(sorted(ranking.shown))
        return (
            f'<p class="note">This drive has no {what} reference: methods are <b>not ranked</b> '
            f"(listed alphabetically).  Shown by default: {esc(shown)}; click a name in a legend to "
            "show any other.</p>"
        )
    return (
        f"<p>Shown by default: the {SHOWN} most accurate by {esc(ranking.by)} "
        f"({esc(', '.join(m for m in ranking.order if m in ranking.shown))}), each with its own "
        "1σ band; click a name in a legend to show any other, double-click a plot to zoom out.</p>"
    )


def render_report(
    drive: Drive,
    est: Series,
    params: Mapping[str, Any] | None = None,
    title: str | None = None,
    command: str | None = None,
    inputs: Sequence[str | Path] = (),
    progress: Callable[[str], None] | None = None,
) -> str:
    """The report as one HTML string.

    ``params``: the estimate's params JSON (method -> identified values, and ``"_skipped"``:
    method -> why it did not run).  ``command``/``inputs`` go to the foot of the page.
    ``progress`` is called with the name of each step.
    """
    tell = progress or (lambda _step: None)
    params = dict(params or {})
    skipped = params.pop(SKIPPED_KEY, {}) or {}
    est = {m: s for m, s in est.items() if m}
    tell("metrics")
    results = evaluate_all(drive, est)
    duration = float(drive.t[-1] - drive.t[0])
    meta = dict(drive.meta)
    scenario = meta.get("scenario") or meta.get("source") or Path(drive.path).name
    title = title or f"sideslip report — {scenario}"
    methods = list(est)
    beta_rank = rank(methods, results, "beta_rmse_deg")
    roll_rank = rank(methods, results, "roll_rmse_deg")
    yaw_rank = rank(methods, results, "yaw_rmse_deg")
    pos_rank = rank(methods, results, "pos_rmse_m")
    outages = gnss_outages(drive)
    sensors = [c for c in COLUMNS if c != "t" and not c.startswith("ref_") and c in drive]
    refs = [c for c in COLUMNS if c.startswith("ref_") and c in drive]

    parts = [
        f"<h1>{esc(title)}</h1>",
        f'<p class="sub">{len(drive):,} rows, {duration:.1f} s (time axes from the drive\'s start, '
        f"t = {drive.t[0]:g} s); vehicle {esc(str(meta.get('vehicle', '?')))}; sensors: "
        f"{esc(', '.join(sensors))}; reference: {esc(', '.join(refs) or 'none')}; "
        f"{len(methods)} methods ran, {len(skipped)} skipped; "
        f"{len(outages)} GNSS outage{'s' if len(outages) != 1 else ''} (shaded red in every plot).</p>",
    ]
    if beta_rank.by is None:
        parts.append(_ranking_note(beta_rank, "sideslip"))
    else:
        best = beta_rank.order[0]
        parts.append(
            f"<p>Most accurate sideslip on this drive: <b>{esc(best)}</b> "
            f"({results[best]['beta_rmse_deg']:.3f}° RMS error above {SPEED_GATE:g} m/s).</p>"
        )
    parts += [
        '<div class="card"><h2>Metrics</h2>',
        f"<p>Errors against the reference on rows faster than {SPEED_GATE:g} m/s, every row "
        "counted; best in each column in green.</p>",
        metrics_html(results, beta_rank.order if beta_rank.by else sorted(results)),
        "</div>",
    ]
    cal = calibration(drive, est)
    if cal:
        parts += ['<div class="card"><h2>Uncertainty calibration (sideslip)</h2>', calibration_html(cal)]
        parts.append("</div>")

    tell("figures")
    o = outages
    yaw_fig = (
        fg.error_plot(drive, est, yaw_rank, "yaw", "ref_yaw", "Yaw (heading) error", o)
        if "ref_yaw" in drive
        else fg.time_plot(drive, est, yaw_rank, "yaw", None, "Yaw from East, counter-clockwise", o)
    )
    sections: list[tuple[str, str, list[Any]]] = [
        (
            "Sideslip angle β",
            _ranking_note(beta_rank, "sideslip"),
            [
                fg.time_plot(drive, est, beta_rank, "beta", "ref_beta", "Sideslip angle β (±1σ bands)", o),
                fg.error_histogram(drive, est, beta_rank, "beta", "ref_beta", "β error distribution"),
                fg.error_plot(drive, est, beta_rank, "beta", "ref_beta", "β error over time (±1σ)", o),
            ],
        ),
        (
            "Roll and road bank",
            _ranking_note(roll_rank, "roll"),
            [
                fg.time_plot(drive, est, roll_rank, "roll", "ref_roll", "Roll angle (body to horizontal)", o),
                fg.time_plot(drive, est, roll_rank, "bank", "ref_bank", "Road bank angle", o),
            ],
        ),
        ("Heading", "", [yaw_fig]),
        ("Trajectory", "", [fg.map_plot(drive, est, pos_rank, o)]),
        ("Speed", "", [fg.speed_plot(drive, o)]),
    ]
    figs: list[dict[str, Any]] = []
    for heading, note, section_figs in sections:
        drawn = [f for f in section_figs if f is not None]
        if not drawn:
            continue
        parts.append(f'<div class="card"><h2>{esc(heading)}</h2>{note}')
        for fig in drawn:
            fid = f"plot-{len(figs)}"
            figs.append({"id": fid, "fig": json.loads(pio.to_json(fig, validate=False))})
            parts.append(f'<div class="plot" id="{fid}"></div>')
        parts.append("</div>")
    parts.append(skipped_html(skipped))
    parts.append(params_html(params, beta_rank.order))
    parts.append(footer_html(command, inputs))
    tell("page")
    data = json.dumps(figs, separators=(",", ":")).replace("</", "<\\/")
    return (
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
        "<meta name='viewport' content='width=device-width, initial-scale=1'>"
        f"<title>{esc(title)}</title><style>{CSS}</style><script>{get_plotlyjs()}</script></head>"
        f"<body>{''.join(parts)}<pre id='js-errors'></pre>"
        f"<script type='application/json' id='figure-data'>{data}</script>"
        f"<script>{SCRIPT}</script></body></html>"
    )


def write_report(
    drive: Drive,
    est: Series,
    out: str | Path,
    params: Mapping[str, Any] | None = None,
    command: str | None = None,
    inputs: Sequence[str | Path] = (),
    progress: Callable[[str], None] | None = None,
) -> None:
    """Write the report atomically to ``out`` (HTML); ``command`` defaults to this process's."""
    cmd = command if command is not None else " ".join(["sideslip", *sys.argv[1:]])
    text = render_report(drive, est, params, command=cmd, inputs=inputs, progress=progress)
    _atomic_write(Path(out), lambda tmp: tmp.write_text(text, encoding="utf-8"))
