"""The shape of the results: what `run` writes to results.json, what `check` returns, what the
reports and replays read. One provenance block (`meta`) for every results file (run, bench, stress).

Typed where the harness decides the shape, and read by the report through these types (mypy checks every
key it reads); the chaos study, the experiments and the equivalence are typed here too, their keys
documented where they are made (dynamics/chaos.py, dynamics/experiments.py, stages/equivalence.py).
Non-finite numbers are written as strings ("inf", "nan"): JSON has none.
"""

from typing import NotRequired, Required, TypedDict

import numpy as np

from ..core.arrays import Json, Matrix
from .stages import Stage

# The one definition of the number every comparison is judged by (verdict/pointwise.error_row computes
# it; the README and the report say it in these words).
SCALED_DEFINITION = (
    "`scaled` is the largest `|a - b|` over the states divided by the largest magnitude the quantity takes "
    "over the states (the larger of `|a|` and `|b|`, over every entry and every state), and at least the "
    "model's own physical scale of it, so that a quantity zero for every source is judged against the model, "
    "not its own rounding (with m the moving bodies' mass, L the chain's size, D the slides' travel and "
    "a = |g| + L max |v|^2: m |g| (L + D) + m L^2 max |v|^2 for energies (m max |v|^2 for a slide), m a L "
    "for forces, a / L for accelerations, m L^2 for M, L + D for positions; for a slide coordinate's force, "
    "acceleration and M: m a, a and m); forces (`bias`, passive forces, `tau_inverse`) by at least "
    "max ||M|| max |v|^2, a physical scale that does not vanish where the velocity terms do (gimbal lock); "
    "`V` is compared up to a constant (the zero of the potential energy, and the bodies welded to the world, "
    "which one reader counts and another does not, change no equation of motion): `|a - b - c|` with c the "
    "midrange of a - b over the states (reported as `constant`), each magnitude taken about its own midrange"
)


class Provenance(TypedDict):
    """Where and how a results file was made."""

    harness_version: str
    git_commit: str  # 12 hex digits, "+dirty" with uncommitted changes, or "unknown"
    date: str  # ISO 8601, UTC
    command: str
    cpu: str
    python: str
    platform: str
    versions: dict[str, str]  # package -> version ("not installed")
    seed: int | None


class WorstState(TypedDict, total=False):
    """Where a row is worst: the state (q, v, tau); for a printed form's "printed parameters" row
    (no state), the printed number and the compiled one (verdict/judge.py)."""

    q: list[float]
    v: list[float]
    tau: list[float]
    printed: float
    compiled: float


class ComparisonRow(TypedDict):
    """One quantity between two sources over the random states (pointwise)."""

    quantity: str  # "M", "bias", "qacc", "tau_inverse", "T", "V", "body_positions", ...
    pair: str  # "hand~mujoco", "hand~pinocchio", "mujoco~pinocchio"
    max_abs: float
    max_rel: float
    scale: float  # the largest magnitude either source gives the quantity over the states (see SCALED_DEFINITION)
    scaled: float  # max_abs / scale: what is judged
    tolerance: float
    tier: str
    passed: bool
    worst_state: WorstState | None
    cond_max: NotRequired[float]
    constant: NotRequired[float]  # V: the constant a - b was compared up to (SCALED_DEFINITION), J


class TermRow(TypedDict):
    """One term of a derivation against one engine at one parameter set."""

    term: str  # "parameters", "mass matrix", "gravity", "velocity", "friction", ..., "acceleration"
    engine: str
    pair: str
    max_abs: float
    max_rel: float
    scale: float
    scaled: float
    tolerance: float
    tier: str
    passed: bool
    worst_state: WorstState | None
    probe: NotRequired[int | None]  # 0: the model's own parameters; k: probe k; None: parameters() misread
    fields: NotRequired[dict[str, list[float]]]  # parameters() misread: per field, [built with, read back]
    parameters: NotRequired[str]
    error: NotRequired[str]  # a function that raised or returned nonsense
    cond_max: NotRequired[float]  # largest cond(M) over the states (solve-tier terms)
    constant: NotRequired[float]  # the potential energy: the constant it was compared up to, J


class Mismatch(TypedDict):
    """One model key checked: what the derivation (or MuJoCo) states against what was compiled."""

    check: str  # "equations~mjcf" or "pinocchio~mujoco"
    key: str
    expected: str
    actual: str
    passed: bool
    why: str  # empty when passed
    defect: NotRequired[str]  # the file's defect that gave MuJoCo other numbers for this key (not a misreading)


class ModelChecks(TypedDict):
    passed: bool
    n_checked: int
    mismatches: list[Mismatch]
    alignments: list[str]  # what the harness aligned between the engines' readings (a URDF; Drake's: "Drake: ...")
    defects: NotRequired[list[str]]  # the file's defects (an invalid inertia), what each reader was given
    floors: NotRequired[list[str]]  # MuJoCo's floors under a valid URDF's point mass or massless link, for every reader
    left_out: NotRequired[
        list[str]
    ]  # the model's constraints (and MuJoCo-only forces) switched off in every comparison


class Pointwise(TypedDict):
    passed: bool
    n_states: int
    seed: int
    rows: list[ComparisonRow]
    not_checked: NotRequired[list[str]]  # quantities the derivation does not provide
    harness_bugs: NotRequired[list[str]]  # the symbolic source against both agreeing engines


class Explanation(TypedDict, total=False):
    """A disagreeing entry of a term, written as a difference from the model's own equations."""

    term: str  # "mass matrix", "gravity", ...
    entry: str  # "M[theta, phi]", "G[theta]", ...
    expected: str  # the model's own expression (sympy's notation, the model's parameter names)
    explained: bool  # a fit reproduced the user's numbers at held-back states
    at_model: bool  # the entry differs at the model's own parameters too (False: only a probe shows it)
    statement: str  # "yours has m_link1 where expected has m_link2 in ...", or why none fits
    difference: str  # yours - expected, when one term explains it
    residual: float  # the fit's largest residual at the held-back states, relative to the entry's scale
    symbols: dict[str, str]  # each parameter named in the statement: its model key and unit


class AsIfReading(TypedDict):
    """One physical reading of a wrong derivation (verdict/asif.py): the body and the parameter its
    equations have instead of the model's, with both values."""

    bodies: list[str]  # the bodies the joint carries (one, or those welded to it)
    kind: str  # "about its joint", "mass twice", "centre twice", ... (verdict/asif.KINDS)
    quantity: str  # "moment of inertia about z", "mass", "distance of the centre from the joint"
    model: float  # the model's value
    yours: float  # the value the derivation behaves as
    unit: str
    statement: str  # "link2's moment of inertia about its joint (0.333 kg m^2) instead of ..."


class AsIf(TypedDict, total=False):
    """The chain a wrong derivation's M and bias are the equations of: the person's tau fitted to the
    chain's inertial parameters (Pinocchio's regressor), on the identifiable combinations only."""

    statement: str  # "your equations are those of this chain with ... [your names: ...]"
    residual: float  # |Y theta* - tau| / |tau| of the fit
    states: int  # the states the fit was made at
    base_parameters: int  # the identifiable combinations of the chain's parameters
    differing: list[str]  # the combinations that differ: "link2's m c_y: -1 instead of -0.5"
    readings: list[AsIfReading]  # the physical readings that reproduce the person's equations
    names: dict[str, str]  # the person's symbols the statement uses: {"c2": "-body/link2/com[1]"}


class StructureFinding(TypedDict, total=False):
    """A property every Lagrangian derivation has that the person's own functions break (verdict/structure.py)."""

    property: str  # "symmetric", "positive definite", "quadratic", "christoffel", "gradient", "potential", "kinetic"
    terms: list[str]  # the verdict's terms it concerns ("velocity", "mass matrix", ...)
    entry: str  # the first entry that breaks it: "(C v)[theta]", "M[theta, phi]", "dG[theta]/dphi", "T"
    entries: list[str]  # every entry that breaks it
    statement: str  # "your velocity terms are not those of your M: (C v)[theta] differs by ..."
    difference: str  # the entry's difference in the person's own symbols; "" where the code could not be traced
    value: float  # the difference at the worst state
    scaled: float  # the largest |difference| over the states, relative to the quantity's scale
    tolerance: float  # what it was judged with there, relative to the same scale
    q: list[float]  # the worst state
    v: list[float]


class TermSummary(TypedDict):
    """One term of a derivation over every engine and probe (verdict/verdict.summarise)."""

    term: str
    passed: bool
    worst_scaled: float
    engine: str
    probe: int | None
    tolerance: float  # the largest the term was judged with
    scale: float
    rows: int


class WorstTerm(TypedDict, total=False):
    """The worst row of the first disagreeing term (a TermRow's fields; a printed form's: with `pair` and
    `parameters`, without `probe`)."""

    term: str
    engine: str
    probe: int | None
    pair: str
    parameters: str
    max_abs: float
    max_rel: float  # a printed form's
    scaled: float
    tolerance: float
    worst_state: WorstState | None
    error: str


class ProbeEntry(TypedDict):
    """One parameter set a derivation was judged at (`Probe.as_dict` in verdict/probes.py)."""

    index: int  # 0: the model's own
    label: str
    changed: dict[str, list[float]]  # Params field -> [model's value, probe's value]


class NotSpd(TypedDict):
    """Where a derivation's mass matrix is not symmetric positive definite (verdict/verdict.definiteness)."""

    what: str  # "not symmetric", "singular" or "indefinite"
    states: int  # how many states
    of: int
    q: list[float]  # the worst state
    smallest_eigenvalue: float


class TermNotes(TypedDict, total=False):
    """What the terms could not check at one parameter set (verdict/verdict.term_rows_at)."""

    errors: dict[str, str]  # term -> why it was not computed
    mass_matrix_not_spd: NotSpd


class Derivation(TypedDict, total=False):
    """The verdict on a derivation (the hand one or a printed form), term by term."""

    name: str
    kind: str
    equations: str  # the module judged
    verdict: str  # "agrees", "disagrees" or "not applicable"
    statement: str
    first_disagreeing_term: str
    failing_terms: list[str]
    hidden_by_model_values: bool
    typed_numbers: dict[str, float]  # fields parameters() returns without reading the model (g = 9.81)
    terms: list[TermRow]
    summary: list[TermSummary]  # per term: rows, worst scaled error, tolerance
    probes: list[ProbeEntry]  # index, label, the parameters changed
    probe_problems: list[str]  # probes that could not be built, and why
    not_looked_for: str  # where probes asked for were not built: what the verdict could not see
    held_at_zero: list[str]  # parameters zero in the model: the terms they scale are not tested
    checked: dict[str, int]  # states at the model, per probe, probes, evaluations
    notes: dict[str, TermNotes]  # per probe: what the terms could not check there
    worst_term: WorstTerm
    exposed_by: list[str]  # the parameters that alone expose a mistake hidden by the model's values
    unstated_assumptions: list[str]  # model numbers the failing term depends on that parameters() does not read
    mass_matrix_not_spd: NotSpd
    disagrees_at: str
    disagrees_where: str
    reason: str  # why not applicable
    not_checked: list[str]  # terms whose functions the derivation does not provide
    explanations: list[Explanation]  # each disagreeing entry as a symbolic difference (verdict/explain.py)
    as_if: AsIf  # the other chain a wrong derivation is the right derivation of (verdict/asif.py)
    structure: list[StructureFinding]  # the properties of a derivation its own functions break (verdict/structure.py)
    # a printed form of the notes (verdict/judge.py)
    notes_equations: list[str]  # the notes' equation numbers it transcribes
    note: str  # what the transcription says of it
    assumes: str  # the parameter equalities it needs ("m1 = m2")


Number = float | str  # a JSON number; "inf" and "nan" as strings (JSON has none)


class TrustSummary(TypedDict):
    """Which engine departs from the reference, from when, and whether it is expected
    (dynamics/freeruns.trust_of, for a chain with no symbolic source)."""

    reference_until: float  # s: the reference agrees with itself at half its tolerance until then
    lyapunov_exponent: Number  # 1/s
    predictability_horizon: Number | None  # s; None: no exponential growth of errors
    trust_rule: str
    horizon_rule: str


class RunTrust(TypedDict):
    """Until when one run agrees with the reference, and why (dynamics/trust.run_trust)."""

    trusted_until: float  # s
    why: str
    departs_at: float | None  # s: its distance to the reference passes the trust limit; None: never
    expected: NotRequired[bool]  # where it departs: the departure is within the run's own threshold


class ReferenceInfo(TypedDict, total=False):
    """How a reference solution was computed and checked (dynamics/reference.reference_trajectory)."""

    method: str
    precision: str
    tolerance: float
    order: int
    steps: int
    timing: dict[str, float]  # s: compile_s, integrate_s, check_..., total_s
    rhs_check: float  # the traced right-hand side against the numpy equations (relative)
    check_method: str | None
    agreement_q: float | None  # rad: the second method against the first
    agreement_v: float | None
    cache: str  # "hit", "miss" or "off"
    cache_file: str | None


class FreeRun(TypedDict, total=False):
    """One free run against the reference (dynamics/freeruns._run_entry, judged by judge_trajectories)."""

    source: str  # "hand", "mujoco", "pinocchio", "symbolic", "drake"
    method: str  # "MuJoCo RK4", "scipy DOP853 rtol 1e-10", ...
    label: str  # a run from another start (the perturbed one)
    stats: dict[str, Json]  # the integrator's own counts and status ("nfev", "status", "reason", ...)
    q: list[list[Number]]  # (K, n) rad
    v: list[list[Number]]  # (K, n) rad/s
    energy: list[Number]  # (K,) J, by the hand equations (or the first source that has them)
    energy_drift: Number | None  # J: max |E - E0|; None where the meter has no energies
    energy_missing: str
    error_vs_hand: list[Number]  # (K,) rad: the largest coordinate's distance to the reference
    max_error_vs_hand: Number
    threshold: list[Number]  # (K,) rad: the run's own threshold
    error_estimate: list[Number]  # (K,) rad
    estimate_how: str
    first_exceeds_threshold: float | None  # s
    counts: bool  # False: shown as information, not judged
    why_not_counted: str
    passed: bool  # absent: not judged
    judged_until: float  # s
    judged_because: str
    threshold_at_judged_end: float
    trust: RunTrust  # dynamics/trust.run_trust
    trust_statement: str


class Trajectories(TypedDict, total=False):
    """The free runs `run` judges (dynamics/freeruns.py), from one start on one grid."""

    q0: list[float]
    v0: list[float]
    tau: list[float]
    t_end: float  # s
    dt_out: float  # s
    t: list[float]  # (K,) s
    reference: str
    reference_info: ReferenceInfo
    threshold: float  # rad: the floor under every run's own threshold
    threshold_rule: str
    safety: float
    runs: list[FreeRun]
    information_only: str  # why no run is judged (a derivation that disagrees, a model alone)
    trust: TrustSummary
    judged_until: float  # s
    judged_because: str


class EquivalenceRow(TypedDict):
    """One quantity of a system against its other formulation, mapped (stages/equivalence.py)."""

    quantity: str  # "M", "bias", "T", "V", "body_positions", "parameters", "trajectory q over 10 s"
    parameters: str  # "model" or "probe k"
    tolerance: float
    max_abs: float
    scaled: float
    passed: bool
    error: NotRequired[str]  # the other module's parameters() or a function raised


class Equivalence(TypedDict):
    """Two formulations of one chain, mapped onto each other (stages/equivalence.check_equivalence)."""

    other: str  # the other system
    map: Matrix | list[list[float]]  # B, q_this = B q_other (an array as computed, lists as read back)
    n_states: int
    probes: int
    rows: list[EquivalenceRow]
    passed: bool


class ExperimentRun(TypedDict, total=False):
    """One dynamic form from both starts at one tolerance (dynamics/experiments.run_experiments)."""

    form: str  # "hand derivation" or a printed form's name
    rtol: float
    status: str  # "ok", "not applicable: ...", or why the integration stopped
    stopped_at: float  # s
    q: list[list[Number]]  # (K, n) rad, from the start as given
    q_perturbed: list[list[Number]]  # (K, n) rad, from the perturbed start
    separation_time: float | None  # s: the two starts differ by more than `resemblance`
    departure_time: float | None  # s: the unperturbed run leaves the accurate solution by as much


class Experiments(TypedDict, total=False):
    """The notes' perturbation experiment (dynamics/experiments.run_experiments), as the stage keeps it."""

    method: str
    accurate: str
    q0: list[float]
    v0: list[float]
    perturbed_coordinate: str
    perturbation: float  # rad, added to the last coordinate
    resemblance: float  # rad
    t: list[float]  # (K,) s
    q_accurate: list[list[Number]]  # (K, n) rad
    accurate_status: str
    runs: list[ExperimentRun]
    notes_experiment: str | None  # what the notes call it; None where they have none
    notes_separation: float | None  # s, as the notes report it
    cache: str  # "hit", "miss" or "off"


# The largest Lyapunov exponent by one method (dynamics/lyapunov.lyapunov_exponent): "lambda" (1/s) is a
# keyword, hence the functional form. "running": [t, lambda(t)] every 10 % of t_end; "spectrum" (variational):
# every exponent; "d0" (two trajectories): their distance.
Lyapunov = TypedDict(
    "Lyapunov",
    {
        "lambda": float,
        "method": str,
        "t_end": float,
        "interval": float,
        "running": list[list[float]],
        "spread": float,
        "seconds": float,
        "spectrum": NotRequired[list[float]],
        "d0": NotRequired[float],
    },
)


class RoundingHorizon(TypedDict):
    """When the rounding of the start grows to `tolerance` (dynamics/flow.horizon_from_rounding)."""

    e0: float  # rad: the rounding
    tolerance: float  # rad
    horizon: float | None  # s; None: not within t_end
    t_end: float


class ChaosSummary(TypedDict):
    """Lyapunov exponents, amplification and horizons from one start (dynamics/lyapunov.chaos_summary)."""

    lyapunov: Lyapunov
    lyapunov_two_trajectories: Lyapunov
    lyapunov_agreement: float
    amplification_at: dict[str, float]  # "2 s" -> amplification
    max_amplification: float
    horizon_from_rounding: RoundingHorizon
    horizon_estimate_from_lambda: float | None  # s
    cache: NotRequired[str]  # the stage cache's "hit", "miss" or "off"


class Judgement(TypedDict):
    """A free-running error against its envelope (dynamics/flow.judge_free_run)."""

    passed: bool
    horizon: float | None  # s; None: the whole grid
    judged_until: float  # s
    safety: float
    tolerance: float  # rad
    max_ratio: float  # largest error / envelope within the horizon
    first_violation: float | None  # s


class FreeRunCheck(TypedDict):
    """One MuJoCo integrator's free run against the reference (dynamics/chaos.free_run_check): errors in rad,
    max over q; window errors as state 2-norms; "..._at" sampled at 1, 2, 5, 10 s."""

    engine: str
    integrator: str
    timestep: float  # s
    max_error: float  # rad
    error_at: dict[str, float]  # "1 s" -> rad
    max_window_error: float
    envelope_at: dict[str, float]
    predicted_at: dict[str, float]
    predicted_horizon: float | None  # s
    prediction_mismatch: float
    judge: Judgement


class MirrorVerdict(TypedDict):
    """Round-off windows (in ulps of max |x|, within the limit) and the free-run difference judged inside
    the envelope (dynamics/chaos._mirror_verdict)."""

    max_window_difference: float
    window_ulps: float
    window_ulps_limit: float
    round_off: bool
    envelope_at: dict[str, float]
    judge: Judgement
    passed: bool


class MirrorCheck(MirrorVerdict):
    """MuJoCo against a mirror of its scheme on another source (dynamics/chaos._integrator_entry)."""

    max_difference: float  # rad
    difference_at: dict[str, float]
    status: NotRequired[str]  # a mirror that diverged, failed or was stopped
    reason: NotRequired[str]
    judged: NotRequired[bool]  # False: cannot be built (an explicit form with damping)
    why_not_judged: NotRequired[str]
    judged_short: NotRequired[str]  # the harness's wall-time budget stopped it: judged until then (the stop, said)


class Convergence(TypedDict):
    """The observed order of an integrator from a timestep sweep (dynamics/chaos.convergence_order): the
    sweep's timesteps (s) and errors (rad), the fitted and pairwise orders (None where too few runs stayed
    finite) and the scheme's expected order."""

    engine: str
    integrator: str
    t_end: float
    timesteps: list[float]
    stable_timestep: float | None
    timesteps_from: str
    errors: list[float]
    order: float | None
    pairwise_orders: list[float] | None
    expected: int


class EnergyChange(TypedDict):
    """A free run's energy against the reference's (J; dynamics/chaos._integrator_entry)."""

    max_abs: float
    relative: float
    rate: float  # J/s


class IntegratorStudy(TypedDict, total=False):
    """One MuJoCo integrator in the chaos study (dynamics/chaos._integrator_entry)."""

    free_run: FreeRunCheck
    mirrors: dict[str, MirrorCheck]  # "mujoco~hand", "mujoco~pinocchio"
    lockstep: dict[str, dict[str, float]]  # "a~b" -> q, v (largest differences), q_ulps, v_ulps
    convergence: Convergence
    energy: EnergyChange


class RoundOff(TypedDict):
    """The window ulps two sources under one scheme may differ by, and what it is made of
    (dynamics/chaos.round_off_limit)."""

    limit: float
    formula: str
    cond_max: float
    max_acceleration: float
    max_state: float
    steps: int
    timestep: float


class ChaosStudy(TypedDict, total=False):
    """The trajectory cross-validation of one system (dynamics/chaos.crossvalidate), as the stage keeps it."""

    q0: list[float]
    v0: list[float]
    tau: list[float]
    t_end: float  # s
    dt_out: float  # s
    timestep: float  # s: the model's
    tolerance: float  # rad
    safety: float
    reference: ReferenceInfo
    chaos: ChaosSummary
    amplification: list[float]  # (K,) on the grid: how much the dynamics amplify an error
    round_off: RoundOff
    integrators: dict[str, IntegratorStudy]  # "RK4", "Euler", "implicit", "implicitfast"
    passed: bool
    cache: str  # "hit", "miss" or "off"


class Readable(TypedDict):
    """One derived expression as plain text and LaTeX."""

    text: str
    latex: str


class DerivedEquations(TypedDict):
    """The model's equations derived symbolically, term by term (symbolic/readable.as_data)."""

    coordinates: list[str]
    T: Readable
    V: Readable
    M: list[list[Readable]]
    Cv: list[Readable]
    G: list[Readable]
    passive: list[Readable]
    parameters: dict[str, str]  # symbol -> "the model key it reads, unit"


class ParameterKeys(TypedDict, total=False):
    """The model keys a parameter sets and their unit (systems/units.parameter_keys)."""

    keys: list[str]
    unit: str  # "" where no key follows the parameter


class Misread(TypedDict):
    """One reader's misreading of a field (audit/audit.py), with the catalogue entry that explains it."""

    reader: str
    key: str
    field: str
    entry: str  # the catalogue's key ("" : cause unknown)
    reported: str  # where the behaviour is reported
    finding: str
    short: str


class AuditRow(TypedDict):
    """One field of the model: what the format means, what each reader read."""

    key: str
    reference: Json
    values: dict[str, Json]  # reader -> its value
    agree: bool
    informational: bool  # no smooth dynamics use it
    misreads: list[Misread]


class MassMatrixGaps(TypedDict):
    """What each reading does to the dynamics (audit/audit.consequences)."""

    n_states: int
    seed: int
    max_abs: dict[str, float]  # reader -> max |M_reader - M_format|
    gravity_max_abs: dict[str, float]  # reader -> max |G_reader - G_format|


class Audit(TypedDict, total=False):
    """The model read by MuJoCo, Pinocchio and Drake side by side (audit/audit.audit_file); an audit that
    cannot be made has only `error` and `passed`."""

    model: str
    format: str
    reference: str
    readers: list[str]
    skipped: dict[str, str]  # reader -> why it did not read the file
    frame: str
    rows: list[AuditRow]
    misreads: list[Misread]
    findings: list[str]
    excluded: list[str]
    warnings: dict[str, list[str]]
    mass_matrix: MassMatrixGaps
    passed: bool
    system: str
    error: str


class Reproducer(TypedDict, total=False):
    """One disagreeing pair of sources and quantity (verdict/reproduce.py): its standalone script's file,
    where it was written (in results.json relative to run's out folder, "reproducers/<file>"; `check
    --reproduce DIR` gives the path it wrote), the state and the numbers the harness saw; or `skipped`."""

    system: str
    pair: str  # "mujoco~pinocchio"
    quantity: str
    file: str  # "<system>_<quantity>_<a>_vs_<b>.py"
    path: str
    state_index: int  # the state's index in the sample compared
    state: dict[str, list[float]]  # q, v, tau
    entry: list[int]  # where in the quantity (M's row and column; [] for T and V)
    numbers: dict[str, float]  # each source's number there
    tolerance: float  # absolute: what the harness allows
    script: str  # the text, until it is written (never in results.json)
    skipped: str  # why no script could be written


class SystemResult(TypedDict, total=False):
    """Everything the harness knows about one system (pipeline.run_system)."""

    name: str
    description: str
    origin: str  # "notes": the repository's models/ and equations/; "user": files from anywhere else
    mjcf: str  # the model file (MJCF or URDF), relative to the checkout for the repository's own
    model_format: str  # "mjcf" or "urdf"
    locked: list[str]  # URDF joints made fixed (System.locked)
    equations: str
    coordinates: list[str]
    joints: list[str]
    bodies: list[str]
    uses: list[str]
    failed: list[str]  # each failing check in one short phrase
    statement: str  # the verdict in one sentence, as `decide` wrote it (verdict/decide.py, Decision.statement)
    parameters: dict[str, float]
    parameter_keys: dict[str, ParameterKeys]  # per parameter: the model keys it sets and their unit
    derived: DerivedEquations | None  # the model's equations derived symbolically (symbolic/readable.as_data)
    timestep: float
    model_checks: ModelChecks
    pointwise: Pointwise
    derivation: Derivation
    variants: list[Derivation]  # the printed forms of the notes (verdict/judge.py)
    trajectories: Trajectories | None
    experiments: Experiments | None
    equivalence: Equivalence | None
    chaos: ChaosStudy | None
    stages: dict[str, Stage]  # each stage's wall seconds, and why it was not run or failed (results/stages.py)
    skipped: list[str]
    audit: Audit  # the model read by MuJoCo, Pinocchio and Drake side by side (audit/audit.py)
    reproducers: list[Reproducer]  # each disagreeing pair's standalone script (verdict/reproduce.py)
    passed: bool


class RunResults(TypedDict):
    """results.json."""

    meta: Provenance
    tolerances: dict[str, dict[str, float | str | None]]  # per tier (`Tolerances.as_dict` in core/tolerances.py)
    systems: dict[str, SystemResult]
    passed: bool


# bench.json, stress.json and chains.json, defined once: studies/bench, studies/stress and studies/chains.py
# write them (importing these types), the report reads them. A key is required where every record written
# has it; the keys only an older harness wrote are NotRequired and say so.


class Spec(TypedDict):
    """One run of the sweep (plan.py): its engine, driver, scheme, setting and value; atol (rtol only)."""

    engine: str
    driver: str
    scheme: str
    setting: str
    value: float
    atol: float | None
    method: NotRequired[str]  # added by Plan.specs
    batch: NotRequired[int]  # a "rollout_batch" run's copies


class Case(TypedDict):
    """The start the bench integrates from (runners.case_for): JSON-able, found again by `system`."""

    system: str
    q0: list[float]
    v0: list[float]
    tau: list[float]
    t_end: float
    dt_out: float


class BenchRow(TypedDict):
    """One row of bench.json: a spec on a system, its status, errors, times and counts."""

    system: str
    method: str
    engine: str
    driver: str
    scheme: str
    setting: str
    value: float  # the setting's value (a tolerance, a timestep)
    atol: NotRequired[float | None]  # rtol runs only
    status: str  # "ok", or why the run failed
    message: str
    error_2s: float | None  # rad
    error_10s: float | None  # rad
    error_horizon: float | None
    t_exceeds_tolerance: float | None
    cpu_s: float | None
    wall_s: float | None
    cpu_s_repeats: list[float]
    wall_s_repeats: list[float]
    executions: int | None
    nfev: int | None
    steps: int | None
    deterministic: bool


class RunSetting(TypedDict):
    """A run of the sweep by its method and setting (the base of FrontPoint and RunBrief)."""

    method: str
    setting: str
    value: float


class FrontPoint(RunSetting, total=False):
    """A run on a Pareto front: its method and setting, its cost and its error (analysis.pareto_front: the
    front's cost key and error key only)."""

    cpu_s: float | None
    wall_s: float | None
    error_2s: float | None
    error_10s: float | None


class TimeToEpsilon(TypedDict):
    """Time to reach an error (analysis.time_to_epsilon): the cheapest run of a method reaching it, or none."""

    system: str
    method: str
    epsilon: float  # rad
    result: str  # "reached" or "not reached"
    setting: str | None
    value: float | None
    cpu_s: float | None
    wall_s: float | None
    error: float | None


class RhsRatio(TypedDict, total=False):
    """Ratio 1: the generated right-hand side against hand-written math (or why it was not measured)."""

    system: str
    value: float | None
    target: float
    passed: bool | None
    per_call_us: dict[str, float]
    numpy_vs_hand_math: float
    calls_per_measurement: int
    repeats: int
    how: str
    why: str


class BySource(TypedDict):
    """One source's own evaluate against its raw calls."""

    harness_us_per_state: float
    raw_us_per_state: float
    ratio: float


class PointwiseSize(TypedDict):
    """The pointwise ratio at one batch size."""

    n_states: int
    value: float
    harness_us_per_state: float
    raw_us_per_state: float
    harness_wall_s: float
    raw_wall_s: float
    by_source: dict[str, BySource]


class PointwiseRatio(TypedDict):
    """Ratio 2 on one system: the worst size's ratio and every size's."""

    system: str
    value: float
    target: float
    passed: bool
    per_size: list[PointwiseSize]
    by_source: dict[str, BySource]
    repeats: int


class PointwiseSummary(TypedDict):
    """Ratio 2 over every system."""

    value: float
    target: float
    passed: bool
    per_system: list[PointwiseRatio]
    how: str


class FlagsRow(TypedDict):
    """MuJoCo's step cost on one system and integrator, with the model's disable flags and without."""

    system: str
    integrator: str
    timestep: float
    model_flags: list[str]
    us_per_step_model_flags: float
    us_per_step_all_enabled: float
    all_enabled_over_model: float
    saving: float
    steps: int
    repeats: int


class FlagsRatio(TypedDict):
    """MuJoCo's disable flags on every system (no target)."""

    target: None
    rows: list[FlagsRow]
    how: str


class ScipyBrief(TypedDict):
    """A scipy run of the sweep in brief (ratios.default_ratio); the default's says whether it reached eps."""

    method: str
    rtol: float
    atol: float | None
    cpu_s: float | None
    error_2s: float | None
    reached: NotRequired[bool]


class DefaultRatio(TypedDict, total=False):
    """Ratio 3: default scipy against the fastest scipy run at its epsilon (or why it was not measured)."""

    system: str
    epsilon: float
    target: float
    value: float | None
    passed: bool | None
    why: str
    default: ScipyBrief
    fastest: ScipyBrief
    fastest_solve_ivp: ScipyBrief | None
    default_over_fastest_solve_ivp: float | None
    would_pass: list[ScipyBrief]
    how: str


class RunBrief(RunSetting):
    """A run of the sweep in brief (ratios.frontier_ratios): every cost and error."""

    cpu_s: float | None
    wall_s: float | None
    error_2s: float | None
    error_10s: float | None


class FrontierEntry(TypedDict):
    """The default path against the fastest run measured at one epsilon."""

    epsilon: float
    default_path: RunBrief | None
    fastest: RunBrief | None
    fastest_contender: RunBrief | None
    ratio: float | None  # default / fastest (CPU)
    why: str | None  # no ratio: why


class Frontier(TypedDict):
    """The default trajectory path against the frontier, per system (no target)."""

    target: None
    epsilons: list[float]
    per_system: dict[str, list[FrontierEntry]]
    how: str


class RunWallTimes(TypedDict, total=False):
    """`lagrange-xval run`'s wall time per condition (ratios.run_wall_times), or why it was not measured."""

    value: float | None
    target: float
    passed: bool | None
    median_s: dict[str, float]
    wall_s_all: dict[str, list[float]]
    cpu_s_all: dict[str, list[float]]
    stages_s: dict[str, dict[str, float]]
    exit_codes: list[int]
    repeats: int
    conditions: dict[str, str]
    how: str
    why: str


class CheckRow(TypedDict):
    """One of the harness's own trajectory checks, timed (checks.measure_checks)."""

    system: str
    check: str
    engine: str
    kind: str  # "accurate", "user", "scheme" or "windows"
    method: str
    cpu_s: float
    wall_s: float
    error_2s: float | None  # rad
    status: str
    timestep: float | None
    windows_ulps_vs_mujoco: NotRequired[float]
    mujoco_windows_cpu_s: NotRequired[float]


class Paired(TypedDict):
    """A check and its fastest run timed again side by side (checks.paired_timings)."""

    cpu_s: float
    fastest_cpu_s: float


class CheckBest(TypedDict):
    """The fastest run computing what a check computes; `spec`: a sweep run's, to time it again."""

    method: str
    setting: str
    value: float | None  # MuJoCo's windows: their timestep
    cpu_s: float | None
    error_2s: float | None
    spec: NotRequired[Spec]


class CheckCost(CheckRow):
    """A check against its fastest run (checks.checks_ratios)."""

    fastest: CheckBest | None
    ratio: float | None
    sweep_ratio: float | None
    paired: Paired | None
    target: float | None
    passed: bool | None
    why: str | None


class Checks(TypedDict):
    """The harness's checks against the fastest runs computing the same."""

    value: float | None
    target: float
    passed: bool
    rows: list[CheckCost]
    how: str


class BenchRatios(TypedDict):
    """bench.json's "ratios"."""

    rhs_fast_path_vs_hand_math: RhsRatio
    pointwise_vs_raw_engine_calls: PointwiseSummary
    default_scipy_vs_fastest_scipy: DefaultRatio
    default_path_vs_frontier: Frontier
    mujoco_disable_flags: FlagsRatio
    run_wall_time: RunWallTimes
    harness_checks_vs_fastest: NotRequired[Checks]


class BenchConfig(TypedDict):
    """bench.json's "config": the plan it ran."""

    quick: bool
    systems: list[str]
    repeats: int
    budget_s: float
    min_timed_s: float
    t_end: float
    dt_out: float
    error_times: list[float]
    atol: str
    horizon_tolerance: float
    epsilons: list[float]
    workers: int | None
    cost: str
    executor: NotRequired[str]


class SystemReference(TypedDict):
    """bench.json's "systems" entry: a system's case, reference and horizon."""

    case: Case
    reference: dict[str, Json]
    horizon_s: float | None
    horizon_window_s: float
    lyapunov_per_s: float | None


class Durations(TypedDict):
    """How long the bench took, and its sweep."""

    duration_s: float
    sweep_s: float


class BenchResults(Durations):
    """bench.json (studies/bench/output.py)."""

    meta: Provenance
    config: BenchConfig
    systems: dict[str, SystemReference]
    rows: list[BenchRow]
    pareto: dict[str, dict[str, list[FrontPoint]]]  # per system, per error ("error_2s", "error_10s")
    time_to_epsilon: list[TimeToEpsilon]
    ratios: BenchRatios
    quick_target_s: float | None


# One run's energy behaviour (energy.classify_energy); "class" is a keyword, hence the call form.
EnergyClass = TypedDict(
    "EnergyClass",
    {
        "E0": float,
        "V_min": float,
        "available": float,  # J: E0 - V_min
        "direction": str | None,  # "loss", "gain" or None
        "t_fail": float | None,
        "rate": float | None,  # J/s
        "r2": float | None,
        "early_envelope": float | None,
        "late_envelope": float | None,
        "max_abs": float,
        "final": float,
        "relative_max": float,
        "relative_final": float,
        "class": str,
        "reason": str | None,
    },
    total=False,
)


class EnergySeries(TypedDict):
    """A drift row's energy change over its horizon, downsampled."""

    t: list[float]
    dE: list[float]  # J


class DriftRow(EnergyClass):
    """Energy over one horizon of one long run (studies/stress/energy.py, drift_rows)."""

    system: str
    engine: str
    integrator: str
    timestep: float
    horizon: float
    q0: np.ndarray
    v0: np.ndarray
    series: EnergySeries


class Trial(TypedDict):
    """A stability run at one timestep judged (studies/stress/stability.py, judged)."""

    timestep: float
    stable: bool
    reason: str | None
    t_fail: float | None
    relative_max: float | None


class Search(TypedDict):
    """The bisection's result (studies/stress/stability.py, max_stable_timestep)."""

    max_stable: float | None  # s
    min_unstable: float | None  # s
    trials: list[Trial]
    reason: str | None


class Found(Search):
    """A bisection with the range it searched and a mirror step's cost (studies/stress/stability.py, searches)."""

    range: list[float]
    step_cost_s: float | None


class StabilityRow(Found):
    """The largest stable timestep of one engine and integrator at one speed and criterion."""

    system: str
    engine: str
    integrator: str
    speed: float  # rad/s
    criterion: str  # "energy x2" or "divergence"
    growth_factor: float | None
    q0: np.ndarray
    v0: np.ndarray
    t_end: float
    bisection_ratio: float


class StiffOutcome(TypedDict):
    """A stiff-friction run judged (none: not run, with why)."""

    stable: bool | None
    reason: str | None
    t_fail: float | None
    max_error: float | None  # rad
    final_error: NotRequired[float | None]
    energy_relative_max: NotRequired[float | None]


class StiffBase(TypedDict):
    """A damping factor on one system: the damping per joint and the reference's method."""

    system: str
    damping_factor: float
    t_end: float
    damping: dict[str, float]
    reference: str


class StiffRun(StiffBase):
    """One engine, integrator and timestep at a damping factor."""

    engine: str
    integrator: str
    eulerdamp: bool
    timestep: float  # s


class StiffRow(StiffRun, StiffOutcome):
    """A stiff-friction row (studies/stress/stability.py, stiff_rows)."""


class SweepBase(TypedDict):
    """One ratio of one conditioning sweep."""

    system: str
    sweep: str
    kind: str
    ratio: float
    overrides: list[list[str | float]]


class ConditioningRow(SweepBase, total=False):
    """A conditioning row: a quantity and pair at one ratio, or the ratio refused (quantity None)."""

    quantity: str | None
    pair: str | None
    refused: str
    cond_median: float
    cond_max: float
    cond_random_max: float
    cond_eq_median: float
    cond_eq_max: float
    q_worst: np.ndarray
    n_states: int
    n_targeted: int
    scaled: float
    max_abs: float
    scale: float
    tier: str
    tolerance: float
    passed: bool
    base_tolerance: float
    passed_base: bool
    c_state: float
    c_state_eq: float
    c_state_all: float
    c_state_eq_all: float
    worst_state_cond: float
    per_cond_eps: float


class Skipped(TypedDict):
    """A section not run on a system, and why."""

    system: str
    section: str
    why: str


class SummarySeries(TypedDict):
    """A sweep's points, for a plot."""

    ratio: list[float]
    cond_max: list[float]
    cond_eq_max: list[float]
    scaled: list[float]
    tolerance: list[float]


class ConditioningSummary(TypedDict):
    """Per system, sweep and quantity: disagreement against cond(M), its slope, C and where tiers fail."""

    system: str
    sweep: str
    kind: NotRequired[str]  # stress.json before the key was named "sweep"
    quantity: str
    points: int
    cond_range: list[float]
    disagreement_range: list[float]
    slope: float | None
    c_state: float
    c_state_eq: float
    c_state_all: float
    c_state_eq_all: float
    base_tolerance: float
    base_tier_fails_from_cond: float | None
    tier_fails_from_cond: float | None
    series: SummarySeries


class SolveTierProposal(TypedDict, total=False):
    """The per-state solve tier the measurements support ({} when nothing was measured)."""

    formula: str
    rtol: float
    eps: float
    margin: float
    current_cond_factor: float | None
    measured_C_cond: float
    measured_C_cond_all_states: float
    C_cond: float
    kappa_from_cond: float | None
    measured_C_cond_eq: float
    measured_C_cond_eq_all_states: float
    C_cond_eq: float
    kappa_from_cond_eq: float | None


class StressResults(TypedDict):
    """stress.json (studies/stress/output.py)."""

    meta: Provenance
    provenance: NotRequired[Provenance]  # stress.json before the block was named "meta"
    quick: bool
    settings: dict[str, object]  # dataclasses.asdict(Settings)
    overrides: list[list[str | float]]
    systems: list[str]
    criteria: dict[str, str]
    drift: list[DriftRow]
    stability: list[StabilityRow]
    conditioning: list[ConditioningRow]
    stiff_friction: list[StiffRow]
    skipped: list[Skipped]
    timing: dict[str, float]
    conditioning_summary: NotRequired[list[ConditioningSummary]]
    solve_tier_proposal: NotRequired[SolveTierProposal]


class SymbolicCost(TypedDict):
    """One chain's derivation and code generation times (codegen_s: where the derivation was in budget)."""

    derive_s: float
    ops_M_Cv: int  # sympy's count_ops of M and C v
    codegen_s: NotRequired[float]


class ChainRow(TypedDict, total=False):
    """One generated chain (studies/chains.py): its sources' time per state, the symbolic times, their
    agreement and cond(M)."""

    kind: Required[str]  # "planar" or "spatial"
    n: Required[int]
    per_state_s: dict[str, dict[str, float]]  # source -> operation ("M", "forward", ...) -> s
    symbolic: SymbolicCost
    worst_scaled: dict[str, float]  # "quantity pair" -> scaled disagreement
    all_within_tiers: bool
    cond_M_max: float


class ChainStop(TypedDict):
    """Where the symbolic source stopped, and why."""

    n: int
    why: str


class ChainsStudy(TypedDict):
    """chains.json (studies/chains.py)."""

    rows: list[ChainRow]
    ns: list[int]
    n_states: int
    repeats: int
    symbolic_budget_s: float
    slopes: dict[str, dict[str, float]]  # chains and source -> operation -> log-log slope
    symbolic_stopped_at: dict[str, ChainStop]


class ReportInput(RunResults, total=False):
    """What the report is rendered from: results.json, with the results of `bench`, `stress` and the chain
    study found beside it (cli/outputs.with_optional_results)."""

    bench: BenchResults
    stress: StressResults
    chains: ChainsStudy
    skipped: str


class CheckData(TypedDict, total=False):
    """What `lagrange_xval.check` computed (Result.data): the verdicts before any trajectory."""

    model_checks: ModelChecks
    pointwise: Pointwise
    derivation: Derivation
    excluded: dict[str, str]  # reader -> why it was left out (it cannot read the file, or misreads it)
    misread: dict[str, str]  # reader -> its known misreading, kept where too few readers would be left


class SurveyRow(TypedDict):
    """One model of a survey (studies/survey.py): `check --model`'s verdict on it, judged from its own
    folder in a process of its own, and the audit's findings."""

    model: str  # its path below the surveyed folder
    format: str  # "mjcf" or "urdf"
    robot: str  # the name the file gives the robot (<robot name>, <mujoco model>), "" if none
    outcome: str  # "pass", "FAIL", "refused" (the harness cannot judge it: why) or "crash" (a timeout, a death)
    why: str  # the verdict's sentence, or the refusal's or the crash's line
    seconds: float  # the check's wall time, audit included
    reproducers: list[str]  # the scripts of the disagreements, relative to the survey's folder
    audit: str  # "agrees", "N finding(s)", or why the audit could not run
    findings: list[str]  # the audit's findings, each reader's misreading named


class SurveyPair(TypedDict):
    """Two files of one robot in the surveyed folder, compared by `audit A B` (audit/twofiles.py)."""

    a: str
    b: str
    robot: str  # the name they share, or "given" (--pairs)
    outcome: str  # "same robot", "differ", "refused" or "crash"
    why: str  # the first findings, or the refusal's line
    findings: list[str]
    seconds: float


class SurveyResults(TypedDict):
    """A whole folder of models judged at once (`lagrange-xval survey DIR`)."""

    folder: str
    executor: str  # "local (N workers)", "dask ..."
    seconds: float  # the survey's wall time
    rows: list[SurveyRow]
    pairs: list[SurveyPair]
    counts: dict[str, int]  # outcome -> models
