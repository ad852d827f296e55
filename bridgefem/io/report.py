"""report.html: one self-contained page (pictures inside, as base64 PNG data) beside the results of ``run`` and
``assess``, for an engineer to read and file.

1. Header: the scene, the verdict in one line (the adequacy factor, or the limit load, and where).
2. Pictures: the bridge and its loads to scale, the adequacy factor against the vehicle's position (assess), the
   mechanism at the critical position with its joints numbered and the line of thrust, the load-deflection curve.
3. Checks side by side: the FE bracket, the rigid-block LP, the conic bounds with a fill (each as a load and, for
   an assessment, as a factor of the vehicle), and whether the FE lies within its own bounds.
4. Warnings, what the model does not include, the software versions.

The numbers a test reads back carry ids (``adequacy-lower``, ``adequacy-upper``, ``lp-factor``, ``critical-x``,
``limit-lower``, ``limit-upper``); each picture is an ``<img>`` whose ``data:`` URL holds its PNG.
"""
from __future__ import annotations

import base64
import html
from pathlib import Path

LIMITATIONS = (
    "No crushing: voussoirs are linear elastic with unlimited compressive strength; hinges form at the very edge of "
    "a joint, so the limit load is an upper estimate for weak masonry.",
    "Joints: zero thickness, no tension, no cohesion, one Coulomb coefficient; no mortar loss, no ring separation.",
    "One ring, one span, in 2D (a slice of the given width): no spandrel walls, no transverse spread, no skew.",
    "Loads: static, vertical, raised together by one factor after the self-weight; no dynamic amplification beyond "
    "what a standard vehicle's load includes, no partial safety factors.",
    "Fill (when present): a continuum, elastic or Mohr-Coulomb; the rigid-block LP carries it as dead load and "
    "spreads each axle through it by the stated dispersion rule.",
    "Small displacements: equilibrium on the undeformed geometry.",
)
STYLE = ("body{font-family:sans-serif;max-width:1000px;margin:2em auto;color:#222}"
         "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #bbb;padding:3px 8px;text-align:left}"
         "img{max-width:100%;border:1px solid #ddd;margin:0.5em 0}.warn{color:#a00}.verdict{font-size:1.2em}"
         "figcaption{font-size:0.9em;color:#555}")


def _esc(value) -> str:
    return html.escape(str(value))


def _png(source: bytes | Path) -> str:
    data = source if isinstance(source, bytes) else Path(source).read_bytes()
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def _figure(name: str, source: bytes | Path | None, caption: str) -> str:
    if not source:
        return ""
    return (f'<figure><img id="fig-{_esc(name)}" alt="{_esc(caption)}" src="{_png(source)}">'
            f"<figcaption>{_esc(caption)}</figcaption></figure>")


def _factor(f: float | None) -> str:
    return "none" if f is None else f"{f:.4f}"


def _kn(n: float | None) -> str:
    return "none" if n is None else f"{n / 1e3:.3f} kN"


def _table(rows: list[tuple], head: tuple = ()) -> str:
    out = ["<table>"]
    if head:
        out.append("<tr>" + "".join(f"<th>{_esc(h)}</th>" for h in head) + "</tr>")
    for row in rows:
        out.append("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>")
    return "".join(out + ["</table>"])


def _warnings(warnings: list[str]) -> str:
    if not warnings:
        return "<p>none</p>"
    return "<ul>" + "".join(f'<li class="warn">{_esc(w)}</li>' for w in warnings) + "</ul>"


def _tail(versions: dict) -> str:
    lim = "<ul>" + "".join(f"<li>{_esc(t)}</li>" for t in LIMITATIONS) + "</ul>"
    ver = _table([(_esc(k), _esc(v)) for k, v in versions.items()], ("software", "version"))
    return f"<h2>What the model does not include</h2>{lim}<h2>Versions</h2>{ver}"


def _page(title: str, body: str) -> str:
    return (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>{_esc(title)}</title>'
            f"<style>{STYLE}</style></head><body>{body}</body></html>\n")


def _checks(data: dict, per: float | None = None) -> list[tuple]:
    """Rows of the checks table of one FE analysis (results.json ``data``): name, load, and the factor of the
    vehicle (load / ``per``, N) when ``per`` is given."""
    def f(n):
        return "" if per is None or n is None else f"{n / per:.4f}"
    lim, lp = data["limit_load"], data.get("lp") or {}
    rows = [("FE limit analysis (the answer)", f'<span id="limit-lower">{_kn(lim["lower"])}</span> to '
             f'<span id="limit-upper">{_kn(lim["upper"])}</span>', f"{f(lim['lower'])} to {f(lim['upper'])}")]
    rows.append((f"rigid-block LP ({_esc(lp.get('model', ''))})", _kn(lp.get("load")), f(lp.get("load"))))
    sb = data.get("static_bound") or {}
    if sb.get("load"):
        rows.append(("static theorem: LP under the FE's own loads", _kn(sb["load"]), f(sb["load"])))
    bounds = data.get("fill_bounds") or {}
    for key in ("lower", "upper"):
        if bounds.get(key):
            rows.append((f"conic {key} bound, rigid-plastic fill", _kn(bounds[key]), f(bounds[key])))
    if bounds.get("lower") and bounds.get("upper") and lim["upper"] is not None:
        inside = bounds["lower"] <= lim["upper"] and lim["lower"] <= bounds["upper"]
        rows.append(("FE within its own conic bounds", "yes" if inside else '<span class="warn">no</span>', ""))
    return rows


def _mechanism(data: dict | None, pictures: dict, mechanism: str, deflection: str) -> str:
    """The collapse of one FE run (results.json's ``data``; None: no FE run): its hinges, sliding joints, where the
    line of thrust touches the faces and the evidence in words, then the mechanism and load-deflection pictures
    with the captions ``mechanism`` and ``deflection``."""
    text = ""
    if data:
        thrust = data.get("line_of_thrust") or {}
        text = (f"<p>Hinges at joints {_esc(data['mechanism']['hinges'])}, sliding joints "
                f"{_esc(data['mechanism']['sliding'])}; the line of thrust touches the intrados at joints "
                f"{_esc(thrust.get('touches_intrados', []))} and the extrados at "
                f"{_esc(thrust.get('touches_extrados', []))}.</p><p>Evidence: {_esc(data['evidence'])}</p>")
    return (text + _figure("mechanism", pictures.get("mechanism"), mechanism)
            + _figure("load_deflection", pictures.get("load_deflection"), deflection))


def run_report(data: dict, pictures: dict) -> str:
    """The report of ``bridgefem run``: results.json's ``data`` and its ``pictures`` (name -> PNG bytes or path:
    "mechanism", "load_deflection")."""
    lim = data["limit_load"]
    verdict = f"{_esc(data['status'])}: limit load {_kn(lim['lower'])} to {_kn(lim['upper'])} for a width of " \
              f"{lim['width']:g} m"
    body = (f"<h1>{_esc(data['scene'])}</h1><p class='verdict'>{verdict}</p>"
            + _mechanism(data, pictures, "collapse mechanism, joints numbered from the left springing, line of thrust "
                         "of the last converged state", "load-deflection curve")
            + "<h2>Checks</h2>" + _table(_checks(data), ("check", "load", ""))
            + "<h2>Warnings</h2>" + _warnings(data["warnings"]) + _tail(data.get("versions", {})))
    return _page(f"bridgefem: {data['scene']}", body)


def assessment_report(data: dict, pictures: dict) -> str:
    """The report of ``bridgefem assess``: assessment.json's ``data`` and the ``pictures`` (name -> PNG bytes:
    "elevation", "adequacy", "mechanism", "load_deflection")."""
    v, crit = data["vehicle"], data.get("critical") or {}
    if data["adequacy_factor"] is not None:
        a = data["adequacy_factor"]
        verdict = (f'adequacy factor <span id="adequacy-lower">{a["lower"]:.4f}</span> to '
                   f'<span id="adequacy-upper">{a["upper"]:.4f}</span> (FE), with the first axle at '
                   f'x = <span id="critical-x">{data["critical_x"]:.3f}</span> m from the left springing')
    else:
        verdict = _esc(data["status"])
    lp = data["lp_adequacy_factor"]
    lp_text = "none" if lp is None else f'<span id="lp-factor">{lp:.4f}</span> at x = {data["lp_critical_x"]:.3f} m'
    axles = ", ".join(f"{p / 1e3:g}" for p in v["axles"])
    rows = [(f"{p['x0']:.3f}", "locked" if p["factor"] is None and p["status"] == "locked" else
             ("" if p["factor"] is None else f"{p['factor']:.4f}"), _esc(p["status"]), "yes" if p["refined"] else "")
            for p in data["positions"]]
    confirmed = [(f"{c['x0']:.3f}", f"{c['load'] / 1e3:.1f}", _esc(c["status"]),
                  f"{c['adequacy']['lower']:.4f} to {_factor(c['adequacy']['upper'])}" if c["adequacy"] else
                  (f"&ge; {c['ceiling']:.4f} (not critical)" if c.get("pruned") else ""),
                  "" if c["lp_factor"] is None else f"{c['lp_factor']:.4f}", _esc(c["proposed_by"]),
                  f"{c['seconds']:.1f}")
                 for c in data["confirmations"]]
    screens = [(_esc(rule), _factor(m["lp_factor"]), f"{m['lp_critical_x']:.3f}")
               for rule, m in (data.get("dispersion_screens") or {}).items()]
    fe = crit.get("results")
    body = (f"<h1>{_esc(data['scene'])}: assessment</h1><p class='verdict'>{verdict}</p>"
            f"<p>Vehicle: {_esc(v['standard'] or 'user-defined')}, axles {axles} kN, spacing {_esc(v['spacing'])} m, "
            f"contact {v['contact_length']:g} m; rigid-block LP screen: least factor {lp_text}; "
            f"{len(data['positions'])} positions, step {data['step']:.3g} m.</p>"
            + _figure("elevation", pictures.get("elevation"), "the bridge and the vehicle at the critical position, "
                      "to scale")
            + _figure("adequacy", pictures.get("adequacy"), "adequacy factor against the first axle's position")
            + _mechanism(fe, pictures, "mechanism at the critical position: joints numbered from the left springing, "
                         "hinges labelled, line of thrust", "load-deflection at the critical position")
            + "<h2>Confirmed positions (FE)</h2>"
            + _table(confirmed, ("first axle x (m)", "vehicle on span (kN)", "status", "FE factor", "LP factor",
                                 "position proposed by", "s"))
            + ("<h2>LP screens by dispersion rule (the fill as dead load)</h2>"
               + _table(screens, ("dispersion", "least LP factor", "at first axle x (m)")) if screens else "")
            + ("<h2>Checks at the critical position</h2>" + _table(_checks(fe, crit["load"]),
                                                                      ("check", "load", "vehicle factor"))
               if fe else "")
            + "<h2>Warnings</h2>" + _warnings(data["warnings"])
            + "<details><summary>Every position screened (rigid-block LP)</summary>"
            + _table(rows, ("first axle x (m)", "LP factor", "status", "refinement")) + "</details>"
            + _tail(data.get("versions", {})))
    return _page(f"bridgefem assessment: {data['scene']}", body)
