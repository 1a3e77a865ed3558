"""Report sections for the chaos-aware trajectory checks, the notes' experiments, the benchmark and
the stress tests. Like report.py, they render plain results data and never recompute physics.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import NOT_RUN, Document, Mark, Num, _new_figure, _pass_mark, _png, _rc, _series, _slug, _vec, sci

WORK_PRECISION_COLOURS = (
    "#1f2937",
    "#2563eb",
    "#d97706",
    "#059669",
    "#7c3aed",
    "#db2777",
    "#0891b2",
    "#65a30d",
    "#dc2626",
    "#9333ea",
    "#ea580c",
    "#475569",
)


def _f(x: Any) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


# ----------------------------------------------------------------------------------------------
# Per system


def system_skipped(doc: Document, name: str, s: dict[str, Any]) -> None:
    stages = s.get("stages") or {}
    if stages:
        doc.table(
            f"Stages of {name} not run or failed",
            ("stage", "outcome"),
            [(k, Mark("bad", v) if str(v).startswith("failed") else v) for k, v in sorted(stages.items())],
        )
    skipped = s.get("skipped")
    if skipped:
        doc.table(f"Work {name} does not need, skipped", ("skipped",), [(x,) for x in skipped])


def system_derivation(doc: Document, name: str, s: dict[str, Any]) -> None:
    """The hand derivation's verdict: every term, at the model's parameters and at every probe."""
    d = s.get("derivation")
    if not d:
        doc.p(f"Derivation verdict: {NOT_RUN}.", "missing")
        return
    ok = d.get("verdict") == "agrees"
    doc.p(
        f"{'✓' if ok else '✗'} The hand derivation: {d.get('statement', d.get('verdict'))}.", "pass" if ok else "fail"
    )
    checked = d.get("checked", {})
    doc.p(
        f"Each term of `{s.get('equations', '?')}` is compared with both engines at {checked.get('states_at_model')} "
        f"random states with the model's own parameters and at {checked.get('states_per_probe')} states with each of "
        f"{checked.get('probes')} probe parameter sets, in which every parameter of the derivation moves by its own "
        "factor in [0.5, 0.8] or [1.25, 2], so that a mistake the model's values hide (l1 l2 for l2², m2 for m1, a "
        "lost factor l) shows. `tolerance` is the smallest change of the term, relative to its largest value over "
        "the states (`scale`), that the check could have seen."
    )
    doc.table(
        f"Terms of {name}'s hand derivation against MuJoCo and Pinocchio, at the model's parameters and every probe",
        ("term", "verdict", "worst scaled error", "engine", "at", "tolerance", "scale"),
        [
            (
                r.get("term"),
                _pass_mark(r.get("passed")),
                Num(r.get("worst_scaled")),
                r.get("engine"),
                "model" if r.get("probe") == 0 else (f"probe {r.get('probe')}" if r.get("probe") else "–"),
                Num(r.get("tolerance"), short=True),
                Num(r.get("scale")),
            )
            for r in d.get("summary", [])
        ],
    )
    failing = [r for r in d.get("terms", []) if not r.get("passed")]
    if failing:
        doc.table(
            f"Where {name}'s failing terms are worst",
            ("term", "pair", "at", "scaled error", "q", "v", "why"),
            [
                (
                    r.get("term"),
                    r.get("pair"),
                    "model" if r.get("probe") == 0 else f"probe {r.get('probe')}",
                    Num(r.get("scaled")),
                    _vec((r.get("worst_state") or {}).get("q", [])),
                    _vec((r.get("worst_state") or {}).get("v", [])),
                    r.get("error", ""),
                )
                for r in failing[:12]
            ],
        )
    probes = [p for p in d.get("probes", []) if p.get("index")]
    if probes:
        doc.table(
            f"Probe parameter sets of {name}'s hand derivation",
            ("probe", "parameters moved (model's value -> probe's)"),
            [
                (
                    p.get("label"),
                    ", ".join(f"{k} {a:.4g} -> {b:.4g}" for k, (a, b) in sorted(p.get("changed", {}).items())),
                )
                for p in probes
            ],
        )
    if d.get("held_at_zero"):
        doc.p(
            f"Zero in the model and so at every probe (the terms they scale are not tested): "
            f"{', '.join(d['held_at_zero'])}.",
            "note",
        )
    for problem in d.get("probe_problems", []):
        doc.p(f"Probe not built: {problem}", "missing")


def system_equivalence(doc: Document, name: str, s: dict[str, Any]) -> None:
    eq = s.get("equivalence")
    if not eq:
        return
    doc.p(
        f"{name} and `{eq['other']}` are the same physical chain in other coordinates (q = B q_other, "
        f"B = {np.asarray(eq['map']).tolist()}): their hand equations must map onto each other."
    )
    doc.table(
        f"{name} mapped onto {eq['other']} at {eq['n_states']} random states and along a trajectory",
        ("quantity", "max abs", "scaled", "tolerance", "pass"),
        [
            (r["quantity"], Num(r["max_abs"]), Num(r["scaled"]), Num(r["tolerance"]), _pass_mark(r["passed"]))
            for r in eq["rows"]
        ],
    )


def system_chaos(doc: Document, name: str, s: dict[str, Any]) -> None:
    cx = s.get("chaos")
    if not cx:
        doc.p(f"Chaos and integrator cross-validation: {NOT_RUN}.", "missing")
        return
    ref, ch = cx.get("reference", {}), cx.get("chaos", {})
    doc.p(
        f"Reference solution: the hand equations by {ref.get('method', '?')} in {ref.get('precision', '?')} "
        f"(tolerance {sci(ref.get('tolerance'))}); a second method ({ref.get('check_method', '?')}) agrees to "
        f"{sci(ref.get('agreement_q'))} rad in q over the run, and the traced right-hand side matches the "
        f"numpy equations to {sci(ref.get('rhs_check'))} (relative)."
    )
    lyap, lyap2 = ch.get("lyapunov", {}), ch.get("lyapunov_two_trajectories", {})
    amp = ch.get("amplification_at", {})
    hz = ch.get("horizon_from_rounding", {})
    rows: list[tuple[Any, ...]] = [
        ("largest Lyapunov exponent, variational equations (1/s)", Num(lyap.get("lambda"), 3)),
        ("largest Lyapunov exponent, two nearby trajectories (1/s)", Num(lyap2.get("lambda"), 3)),
    ]
    rows += [
        (f"amplification of an initial error at {k}", Num(v, 3))
        for k, v in sorted(amp.items(), key=lambda kv: _f(kv[0].split()[0]))
    ]
    rows += [
        (
            f"predictability horizon at {sci(hz.get('tolerance'))} rad from rounding ({sci(hz.get('e0'))}) (s)",
            Num(hz.get("horizon"), 3),
        ),
        ("the same, estimated from the exponent (s)", Num(ch.get("horizon_estimate_from_lambda"), 3)),
    ]
    doc.table(f"Chaos of {name} from its initial state", ("quantity", "value"), rows)
    integ = cx.get("integrators", {})
    if not integ:
        return
    rows = []
    for iname, r in sorted(integ.items()):
        fr = r.get("free_run", {})
        judge = fr.get("judge", {})
        mirrors = r.get("mirrors", {})
        conv = r.get("convergence", {})
        energy = r.get("energy", {})
        rows.append(
            (
                iname,
                Num(fr.get("max_error")),
                _pass_mark(judge.get("passed")),
                Num(judge.get("judged_until"), 3),
                Num((mirrors.get("mujoco~hand") or {}).get("max_difference")),
                Num((mirrors.get("mujoco~pinocchio") or {}).get("max_difference")),
                Num(conv.get("order"), 3),
                Num(conv.get("expected"), 2),
                Num(energy.get("relative")),
            )
        )
    doc.table(
        f"MuJoCo integrators on {name} at the MJCF timestep {sci(cx.get('timestep'))} s: free run against the "
        f"reference, mirrors, convergence, energy",
        (
            "integrator",
            "free-run max error (rad)",
            "inside envelope",
            "judged until (s)",
            "mirror hand (rad)",
            "mirror Pinocchio (rad)",
            "order",
            "expected",
            "energy drift (rel.)",
        ),
        rows,
    )
    doc.p(
        "The mirrors apply MuJoCo's own scheme (operation for operation) to the hand equations and to "
        "Pinocchio's ABA: a stepped MuJoCo trajectory and its mirror differ by rounding only, amplified by "
        "the chaos. The free run is judged against an error envelope that grows with the measured "
        "amplification, inside the predictability horizon; the order is measured from a timestep sweep."
    )


def system_experiments(doc: Document, name: str, s: dict[str, Any]) -> None:
    ex = s.get("experiments")
    if not ex:
        doc.p(f"The notes' experiments: {NOT_RUN}.", "missing")
        return
    coord = ex.get("perturbed_coordinate", "q")
    doc.p(
        f"The notes' experiment: from q0 = {np.asarray(ex['q0']).tolist()}, v0 = {np.asarray(ex['v0']).tolist()}, "
        f"and from {coord}0 + {ex['perturbation']:g}, every dynamic form integrated by {ex['method']}. "
        f"Separation: when the two starts differ by more than {ex['resemblance']:g} rad; departure: when the "
        f"unperturbed run departs by as much from the accurate solution ({ex['accurate']})."
    )
    t_end = _f(_series(ex["t"])[-1]) if ex.get("t") else float("nan")

    def when(x: Any) -> str:
        return f"{_f(x):.2f} s" if x is not None else f"never ({t_end:g} s)"

    rows = [
        (
            r["form"],
            Num(r["rtol"], 1),
            when(r.get("separation_time")),
            when(r.get("departure_time")),
            r.get("status", ""),
        )
        for r in ex.get("runs", [])
    ]
    doc.table(
        f"When the notes' two starts stop resembling each other, {name}",
        ("form", "rtol", "separation", "departure", "status"),
        rows,
    )
    by_rtol = {r["rtol"]: r for r in ex.get("runs", []) if r["form"] == "hand derivation"}
    loose, tight = by_rtol.get(1e-3), by_rtol.get(1e-6)
    if loose and tight:
        finding = (
            f"With the hand derivation at Matlab's default tolerance (rtol 1e-3) the two starts separate at "
            f"{when(loose.get('separation_time'))}, and the unperturbed run has itself left the accurate "
            f"solution at {when(loose.get('departure_time'))}: "
        )
        if loose.get("departure_time") is not None and (
            loose.get("separation_time") is None or _f(loose["departure_time"]) <= _f(loose["separation_time"])
        ):
            finding += "the loose solver's own error, not only the 0.01 rad perturbation, makes them part. "
        else:
            finding += "the perturbation, amplified by the chaos, makes them part. "
        tight_sep = tight.get("separation_time")
        later = f"at {when(tight_sep)}" if tight_sep is not None else f"later than {t_end:g} s"
        finding += f"At rtol 1e-6 they separate {later} (the notes report about 7 s by eye, from their Figs 3-4)."
        doc.p(finding)
    hand = [r for r in ex.get("runs", []) if r["form"] == "hand derivation" and "q" in r]
    if hand:
        doc.figure(
            f"img/{name}_experiment.png",
            _experiment_figure(name, ex, hand),
            f"{coord} against time for the notes' two starts at both tolerances, {name}",
            f"The last coordinate ({coord}) from both starts, at each tolerance, with the accurate "
            "solution: at Matlab's default tolerance the solver's own error separates the curves as "
            "early as the perturbation does.",
        )


def _experiment_figure(name: str, ex: dict[str, Any], runs: list[dict[str, Any]]) -> bytes:
    t = _series(ex["t"])
    acc = _series(ex["q_accurate"])
    with _rc():
        fig, axes = _new_figure(8.6, 0.6 + 1.7 * len(runs), nrows=len(runs), sharex=True)
        for ax, r in zip(axes, runs, strict=True):
            q, qb = _series(r["q"]), _series(r["q_perturbed"])
            ax.plot(t, acc[:, -1], color="#9ca3af", linewidth=2.4, label="accurate (DOP853 1e-12)")
            ax.plot(t, q[:, -1], color="#2563eb", linewidth=1.2, label=f"start as printed, rtol {r['rtol']:g}")
            ax.plot(
                t,
                qb[:, -1],
                color="#d97706",
                linewidth=1.2,
                linestyle="--",
                label=f"perturbed by {ex['perturbation']:g}, rtol {r['rtol']:g}",
            )
            ax.set_ylabel(f"{ex.get('perturbed_coordinate', 'q')} (rad)")
            ax.legend(loc="lower left", ncols=3)
        axes[0].set_title(f"{name}: the notes' perturbation experiment (RK45, as ode45)")
        axes[-1].set_xlabel("t (s)")
        return _png(fig)


# ----------------------------------------------------------------------------------------------
# Benchmark


def section_bench(doc: Document, bench: dict[str, Any] | None) -> None:
    if not bench:
        doc.p(
            f"Benchmark: {NOT_RUN} (`lagrange-xval bench` writes reports/bench.json; this report shows it "
            "when present).",
            "missing",
        )
        return
    cfg = bench.get("config", {})
    doc.p(
        f"`{bench.get('meta', {}).get('command', 'lagrange-xval bench')}` on {bench.get('meta', {}).get('cpu', '?')}, "
        f"{bench.get('meta', {}).get('date', '?')}: {'quick plan' if cfg.get('quick') else 'full plan'}, "
        f"{cfg.get('repeats')} repeat(s), median CPU time of interleaved repeats; errors against the reference "
        f"solution at t = 2 s and 10 s."
    )
    rows = []
    for key, r in sorted(bench.get("ratios", {}).items()):
        if not isinstance(r, dict) or "value" not in r:
            continue
        rows.append(
            (
                key.replace("_", " "),
                Num(r.get("value"), 3),
                Num(r.get("target"), 2),
                _pass_mark(r.get("passed")) if r.get("passed") is not None else "not measured",
            )
        )
    if rows:
        doc.table("The fast-harness ratios, measured in the same run", ("ratio", "measured", "target", "verdict"), rows)
    flags = bench.get("ratios", {}).get("mujoco_disable_flags", {})
    frows = (
        [
            (
                r.get("system"),
                r.get("integrator"),
                Num(r.get("us_per_step_model_flags"), 3),
                Num(r.get("us_per_step_all_enabled"), 3),
                f"{100 * _f(r.get('saving')):.0f}%",
            )
            for r in flags.get("rows", [])
        ]
        if isinstance(flags, dict)
        else []
    )
    if frows:
        doc.table(
            "MuJoCo step cost with the scene's disable flags and with everything enabled (us per step)",
            ("system", "integrator", "model flags", "all enabled", "saving"),
            frows,
        )
    rows_all = bench.get("rows", [])
    for system in bench.get("systems", []):
        srows = [r for r in rows_all if r.get("system") == system]
        if not srows:
            continue
        doc.figure(
            f"img/bench_{_slug(system)}.png",
            _work_precision_figure(system, srows),
            f"Work-precision diagram of {system}",
            "CPU time against the error at t = 10 s, one line per method (log-log); lower left is better.",
        )
        front = (bench.get("pareto", {}) or {}).get(system, [])
        if isinstance(front, dict):
            front = front.get("10s") or front.get("error_10s") or next(iter(front.values()), [])
        if front:
            doc.table(
                f"Pareto front of {system} (CPU time against error at 10 s)",
                ("method", "setting", "CPU (s)", "error at 10 s (rad)"),
                [
                    (
                        r.get("method"),
                        f"{r.get('setting', '')} {sci(r.get('value'))}",
                        Num(r.get("cpu_s")),
                        Num(r.get("error_10s")),
                    )
                    for r in front
                ],
            )
        tte = [r for r in bench.get("time_to_epsilon", []) if r.get("system") == system]
        if tte:
            eps = sorted({r["epsilon"] for r in tte}, reverse=True)
            methods = sorted({r["method"] for r in tte})
            table = []
            for m in methods:
                cells: list[Any] = [m]
                for e in eps:
                    hit = next((r for r in tte if r["method"] == m and r["epsilon"] == e), None)
                    cells.append(Num(hit["cpu_s"], 3) if hit and hit.get("result") == "reached" else "not reached")
                table.append(tuple(cells))
            doc.table(
                f"CPU time (s) to reach an error below eps at t = 2 s, {system}",
                ("method", *[f"eps {e:g}" for e in eps]),
                table,
            )


def _work_precision_figure(system: str, rows: list[dict[str, Any]]) -> bytes:
    methods = sorted({r["method"] for r in rows})
    with _rc():
        fig, (ax,) = _new_figure(8.6, 4.2)
        for i, m in enumerate(methods):
            pts = sorted(
                (_f(r.get("cpu_s")), _f(r.get("error_10s")))
                for r in rows
                if r["method"] == m and r.get("status") == "ok"
            )
            pts = [(c, e) for c, e in pts if c > 0 and e > 0 and np.isfinite(e)]
            if not pts:
                continue
            c, e = zip(*pts, strict=True)
            ax.loglog(
                c,
                e,
                marker="o",
                markersize=3,
                linewidth=1.1,
                label=m,
                color=WORK_PRECISION_COLOURS[i % len(WORK_PRECISION_COLOURS)],
            )
        ax.set_xlabel("CPU time (s)")
        ax.set_ylabel("error at t = 10 s (rad)")
        ax.set_title(f"{system}: work against precision")
        ax.legend(loc="upper right", ncols=2, fontsize=7)
        return _png(fig)


# ----------------------------------------------------------------------------------------------
# Stress


def section_stress(doc: Document, stress: dict[str, Any] | None) -> None:
    if not stress:
        doc.p(
            f"Stress tests: {NOT_RUN} (`lagrange-xval stress` writes reports/stress.json; this report shows it "
            "when present).",
            "missing",
        )
        return
    prov = stress.get("provenance", {})
    doc.p(
        f"`{prov.get('command', 'lagrange-xval stress')}`, {prov.get('date', '?')}"
        f"{' (quick plan)' if stress.get('quick') else ''}."
    )
    crit = stress.get("criteria", {})
    if crit.get("instability"):
        doc.p(f"Instability: {crit['instability']}")
    stab = stress.get("stability", [])
    if stab:
        keys = sorted({(r["system"], r["integrator"], r["engine"], _f(r["speed"])) for r in stab})
        table = []
        for system, integrator, engine, speed in keys:
            by = {
                r["criterion"]: r
                for r in stab
                if (r["system"], r["integrator"], r["engine"], _f(r["speed"])) == (system, integrator, engine, speed)
            }
            cells = [system, integrator, engine, Num(speed, 2)]
            for c in ("energy x2", "divergence"):
                r = by.get(c)
                cells.append(Num(r["max_stable"], 2) if r and r.get("max_stable") is not None else "–")
            table.append(tuple(cells))
        doc.table(
            "Largest stable timestep (s), by bisection over log(dt)",
            ("system", "integrator", "engine", "initial speed (rad/s)", "energy x2 criterion", "divergence only"),
            table,
        )
    drift = stress.get("drift", [])
    if drift:
        doc.table(
            "Energy over long horizons at the MJCF timestep (conservative systems)",
            ("system", "integrator", "engine", "horizon (s)", "class", "max |dE| / available", "rate (J/s)"),
            [
                (
                    r.get("system"),
                    r.get("integrator"),
                    r.get("engine"),
                    Num(r.get("horizon"), 3),
                    r.get("class"),
                    Num(r.get("relative_max")),
                    Num(r.get("rate")),
                )
                for r in drift
            ],
        )
        doc.figure(
            "img/stress_drift.png",
            _drift_figure(drift),
            "Energy error against time over the long horizon",
            "E(t) - E(0) of each integrator on the first conservative system, MuJoCo's own runs.",
        )
    cond = stress.get("conditioning_summary", [])
    if cond:
        doc.table(
            "Disagreement between the sources against the mass matrix's conditioning",
            ("system", "sweep", "quantity", "cond range", "disagreement range", "flat 1e-10 tier fails from cond"),
            [
                (
                    r.get("system"),
                    r.get("sweep", r.get("kind")),
                    r.get("quantity"),
                    "{} to {}".format(*(sci(x) for x in (r.get("cond_range") or [None, None]))),
                    f"{sci((r.get('disagreement_range') or [None, None])[0])} to "
                    f"{sci((r.get('disagreement_range') or [None, None])[1])}",
                    sci(r.get("base_tier_fails_from_cond")) if r.get("base_tier_fails_from_cond") else "never",
                )
                for r in cond
            ],
        )
        doc.figure(
            "img/stress_conditioning.png",
            _conditioning_figure(stress.get("conditioning", [])),
            "Disagreement of the sources against cond(M)",
            "Largest disagreement in q'' (scaled) against the largest cond(M) of each sweep point; the solve "
            "tier max(1e-10, 20 cond(M) eps) dashed, cond(M) eps dotted.",
        )
    prop = stress.get("solve_tier_proposal", {})
    if prop:
        doc.p(
            f"Measured: the worst state needed {sci(prop.get('measured_C_cond'))} cond(M) eps; the solve tier "
            f"uses C = 20 (formula: {prop.get('formula', '')})."
        )
    stiff = stress.get("stiff_friction", [])
    if stiff:
        doc.table(
            "Stiff friction: the gimbal with damping up to 1e3 times the notes' value",
            ("damping factor", "integrator", "engine", "timestep (s)", "stable", "max error (rad)"),
            [
                (
                    Num(r.get("damping_factor"), 1),
                    r.get("integrator"),
                    r.get("engine"),
                    Num(r.get("timestep"), 1),
                    _pass_mark(r.get("stable"), "stable", "unstable"),
                    Num(r.get("max_error")),
                )
                for r in sorted(
                    stiff,
                    key=lambda r: (
                        _f(r.get("damping_factor")),
                        r.get("integrator", ""),
                        r.get("engine", ""),
                        _f(r.get("timestep")),
                    ),
                )
            ],
        )


def _drift_figure(drift: list[dict[str, Any]]) -> bytes:
    system = drift[0].get("system")
    runs = [r for r in drift if r.get("system") == system and r.get("engine") == "mujoco" and r.get("series")]
    with _rc():
        fig, (ax,) = _new_figure(8.6, 3.2)
        for i, r in enumerate(runs):
            ser = r["series"]
            t, de = _series(ser.get("t", [])), _series(ser.get("dE", []))
            if len(t) and len(t) == len(de):
                ax.plot(
                    t,
                    de,
                    linewidth=1.0,
                    color=WORK_PRECISION_COLOURS[i % len(WORK_PRECISION_COLOURS)],
                    label=f"{r.get('integrator')} ({r.get('horizon'):g} s)",
                )
        ax.set_xlabel("t (s)")
        ax.set_ylabel("E(t) - E(0) (J)")
        ax.set_title(f"{system}: energy error of MuJoCo's integrators")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper left", ncols=2)
        return _png(fig)


def _conditioning_figure(rows: list[dict[str, Any]]) -> bytes:
    eps = float(np.finfo(float).eps)
    pts = [(_f(r.get("cond_max")), _f(r.get("scaled"))) for r in rows if r.get("quantity") == "qacc"]
    pts = [(c, e) for c, e in pts if c > 0 and np.isfinite(e)]
    with _rc():
        fig, (ax,) = _new_figure(8.6, 3.6)
        if pts:
            c, e = zip(*pts, strict=True)
            ax.loglog(c, np.maximum(e, 1e-18), "o", markersize=3, color="#2563eb", label="measured (any pair)")
            grid = np.logspace(0, np.log10(max(c)) + 0.3, 50)
            ax.loglog(grid, np.maximum(1e-10, 20 * grid * eps), "--", color="#dc2626", label="solve tier")
            ax.loglog(grid, grid * eps, ":", color="#6b7280", label="cond(M) eps")
        ax.set_xlabel("cond(M)")
        ax.set_ylabel("scaled disagreement in q''")
        ax.set_title("Sources' disagreement against conditioning")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper left")
        return _png(fig)
