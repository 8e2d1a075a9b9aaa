"""``report.html``: one self-contained page (no external resource: plots embedded as base64 PNG, inline
CSS, no script) with the verdict per bearing, the numbers and the views of a run."""

from __future__ import annotations

import base64
import html
import json
from pathlib import Path

from oilwatch.outputs.atomic import write_text_atomic

from .views import VIEW_FILES

CAPTIONS = {
    "trend": "Flowrate estimate of each bearing with its +-2 std band and the alarms",
    "centerline": "Shaft centreline: average journal position inside the clearance circle over time",
    "orbits": "1x-filtered orbits at the start and at the end of the record",
    "probe_health": "Probe health over time",
}
STYLE = (
    "body{font-family:sans-serif;max-width:1000px;margin:1em auto;color:#222}"
    "table{border-collapse:collapse;margin:0.5em 0}"
    "td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}td.text{text-align:left}"
    "th{background:#eee}.bad{color:#b00;font-weight:bold}.ok{color:#060;font-weight:bold}"
    "img{max-width:100%}figure{margin:1em 0}figcaption{font-size:90%;color:#555}"
    "pre{background:#f6f6f6;padding:0.5em;font-size:80%;overflow-x:auto}"
)


def _number(value, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def _yes_no(value: bool | None) -> str:
    """A person's word for a flag: "-" while the estimator has not reported it."""
    return "-" if value is None else ("yes" if value else "no")


def _flagged(seconds: float) -> str:
    """How long a probe was flagged faulty; a probe never flagged says so rather than "0.000"."""
    return "never" if seconds <= 0.0 else f"{seconds:.3f}"


def write_report(summary: dict, out_dir: Path) -> Path:
    """Write ``out_dir/report.html`` from the summary and the view PNGs beside it; return its path."""
    record = summary["record"]
    rows = []
    for b in (1, 2):
        nominal = summary[f"q{b}_nominal_ml_min"]
        verdict = summary["verdict"][f"bearing{b}"]
        css = "ok" if verdict.startswith("healthy") and "NOT TRUSTWORTHY" not in verdict else "bad"
        q = summary[f"q{b}_final_ml_min"]
        pct = None if q is None else 100.0 * q / nominal
        rows.append(
            f"<tr><th>bearing {b}</th><td class='{css} text'>{html.escape(verdict)}</td>"
            f"<td>{_number(q, 1)}</td><td>{_number(nominal, 1)}</td><td>{_number(pct, 2)}</td>"
            f"<td>{_number(summary[f'q{b}_std_final_ml_min'], 2)}</td></tr>"
        )
    alarms = (
        "".join(
            f"<tr><td>{a['bearing']}</td><td>{a['time_s']:.3f}</td><td>{_number(a.get('cleared_s'), 3)}</td>"
            f"<td>{_yes_no(a['consistent'])}</td></tr>"
            for a in summary["alarms"]
        )
        or "<tr><td colspan='4'>no alarm</td></tr>"
    )
    estimated = summary["estimator"].get("offset_prior_std_um", 0.0) or summary["estimator"].get(
        "baseline_file"
    )
    probes = "".join(
        f"<tr><th>{name}</th><td>"
        + (f"{p['offset_um']:+.2f} &plusmn; {p['offset_std_um']:.2f}" if estimated else "known (0)")
        + f"</td><td>{html.escape(str(p['status_final'] or '-'))}</td>"
        + f"<td>{_flagged(p['flagged_s'])}</td></tr>"
        for name, p in summary.get("probes", {}).items()
    )
    facts = [
        ("record", record["source"]),
        ("format", record["format"]),
        ("rows", record["rows"]),
        ("sample rate [Hz]", _number(record["sample_rate_hz"], 1)),
        ("estimator rate [Hz]", _number(record["estimator_rate_hz"], 1)),
        ("anti-alias FIR taps", record["anti_alias_taps"]),
        ("duration estimated [s]", _number(summary["duration_s"], 3)),
        ("final window [s]", _number(summary["final_window_s"], 3)),
        ("keyphasor pulses", record["keyphasor_pulses"]),
        ("time origin shift [s]", f"{record['time_shift_s']:.6f}"),
        ("speed source", record["speed_source"]),
        ("gaps bridged", f"{record['gap_count']} ({record['missing_samples']} missing samples)"),
        ("machine file", summary["machine_file"]),
        ("estimator", summary["estimator"]["model"]),
        ("operating point", summary["estimator"].get("operating_point", "-")),
        (
            "probe offsets' prior",
            summary["estimator"].get("baseline_file")
            or f"{summary['estimator'].get('offset_prior_std_um', 0.0):g} um std",
        ),
        ("real-time factor", _number(summary["realtime_factor"], 1)),
    ]
    fact_rows = "".join(
        f"<tr><th>{html.escape(k)}</th><td class='text'>{html.escape(str(v))}</td></tr>" for k, v in facts
    )
    figures = []
    for name, file in VIEW_FILES.items():
        path = out_dir / file
        if path.is_file():
            data = base64.b64encode(path.read_bytes()).decode("ascii")
            figures.append(
                f"<figure><img alt='{name}' src='data:image/png;base64,{data}'>"
                f"<figcaption>{html.escape(CAPTIONS[name])}</figcaption></figure>"
            )
    page = (
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
        f"<title>oilwatch estimate: {html.escape(record['source'])}</title><style>{STYLE}</style>"
        "</head><body>"
        f"<h1>Oil supply of {html.escape(record['source'])}</h1>"
        "<h2>Verdict</h2><table><tr><th></th><th>verdict</th><th>flowrate [ml/min]</th>"
        "<th>nominal [ml/min]</th><th>% of nominal</th>"
        f"<th>std [ml/min]</th></tr>{''.join(rows)}</table>"
        # each bearing's own nominal is in its row: the bearings of a machine may have different ones
        f"<p>Final values: mean over the last {summary['final_window_s']:.3g} s.</p>"
        "<h2>Alarms</h2><table><tr><th>bearing</th><th>set [s]</th><th>cleared [s]</th>"
        f"<th>model consistent</th></tr>{alarms}</table>"
        "<h2>Probes</h2><table><tr><th>probe</th><th>zero offset [um] (estimate &plusmn; std)</th>"
        f"<th>status at the end</th><th>flagged faulty [s]</th></tr>{probes}</table>"
        f"<h2>Record and estimator</h2><table>{fact_rows}</table>"
        f"<h2>Views</h2>{''.join(figures)}"
        "<h2>Summary</h2><details><summary>summary.json</summary>"
        f"<pre>{html.escape(json.dumps(_without_views(summary), indent=1))}</pre></details>"
        "</body></html>\n"
    )
    path = out_dir / "report.html"
    return write_text_atomic(path, page)


def _without_views(summary: dict) -> dict:
    return {key: value for key, value in summary.items() if key not in ("views", "report_html")}
