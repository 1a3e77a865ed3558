"""The shape of the results: what `run` writes to results.json, what `check` returns, what the
reports and replays read. One provenance block (`meta`) for every results file (run, bench, stress).

Typed where the harness decides the shape, and read by the report through these types (mypy checks every
key it reads); the chaos study, the experiments and the equivalence stay plain mappings (`dict[str, Any]`),
their keys documented where they are made (dynamics/chaos.py, pipeline.py). Non-finite numbers are written
as strings ("inf", "nan"): JSON has none.
"""

from typing import Any, NotRequired, TypedDict

from .stages import Stage

# The one definition of the number every comparison is judged by (verdict/pointwise.error_row computes
# it; the README and the report say it in these words).
SCALED_DEFINITION = (
    "`scaled` is the largest `|a - b|` over the states divided by the largest magnitude the quantity takes "
    "over the states (the larger of `|a|` and `|b|`, over every entry and every state); forces (`bias`, "
    "passive forces, `tau_inverse`) by at least max ||M|| max |v|^2, a physical scale that does not vanish "
    "where the velocity terms do (gimbal lock)"
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


class Mismatch(TypedDict):
    """One model key checked: what the derivation (or MuJoCo) states against what was compiled."""

    check: str  # "equations~mjcf" or "pinocchio~mujoco"
    key: str
    expected: str
    actual: str
    passed: bool
    why: str  # empty when passed


class ModelChecks(TypedDict):
    passed: bool
    n_checked: int
    mismatches: list[Mismatch]
    alignments: list[str]  # what the harness aligned between the engines' readings (a URDF; Drake's: "Drake: ...")
    defects: NotRequired[list[str]]  # the file's defects (an invalid inertia), what each reader was given
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
    scaled: float
    tolerance: float
    worst_state: WorstState | None
    error: str


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
    probes: list[dict[str, Any]]  # index, label, the parameters changed
    probe_problems: list[str]  # probes that could not be built, and why
    held_at_zero: list[str]  # parameters zero in the model: the terms they scale are not tested
    checked: dict[str, int]  # states at the model, per probe, probes, evaluations
    notes: dict[str, Any]  # per probe: what the terms could not check there
    worst_term: WorstTerm
    exposed_by: list[str]  # the parameters that alone expose a mistake hidden by the model's values
    unstated_assumptions: list[str]  # model numbers the failing term depends on that parameters() does not read
    mass_matrix_not_spd: dict[str, Any]
    disagrees_at: str
    disagrees_where: str
    reason: str  # why not applicable
    not_checked: list[str]  # terms whose functions the derivation does not provide
    explanations: list[Explanation]  # each disagreeing entry as a symbolic difference (verdict/explain.py)
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


class FreeRun(TypedDict, total=False):
    """One free run against the reference (dynamics/freeruns._run_entry, judged by judge_trajectories)."""

    source: str  # "hand", "mujoco", "pinocchio", "symbolic", "drake"
    method: str  # "MuJoCo RK4", "scipy DOP853 rtol 1e-10", ...
    label: str  # a run from another start (the perturbed one)
    stats: dict[str, Any]
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
    trust: dict[str, Any]  # dynamics/trust.run_trust
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
    reference_info: dict[str, Any]
    threshold: float  # rad: the floor under every run's own threshold
    threshold_rule: str
    safety: float
    runs: list[FreeRun]
    information_only: str  # why no run is judged (a derivation that disagrees, a model alone)
    trust: TrustSummary
    judged_until: float  # s
    judged_because: str


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
    parameter_keys: dict[str, dict[str, Any]]  # per parameter: the model keys it sets and their unit
    derived: dict[str, Any] | None  # the model's equations derived symbolically (symbolic/readable.as_data)
    timestep: float
    model_checks: ModelChecks
    pointwise: Pointwise
    derivation: Derivation
    variants: list[Derivation]  # the printed forms of the notes (verdict/judge.py)
    trajectories: Trajectories | None
    experiments: dict[str, Any] | None
    equivalence: dict[str, Any] | None
    chaos: dict[str, Any] | None
    stages: dict[str, Stage]  # each stage's wall seconds, and why it was not run or failed (results/stages.py)
    skipped: list[str]
    audit: dict[str, Any]  # the model read by MuJoCo, Pinocchio and Drake side by side (audit/audit.py)
    passed: bool


class RunResults(TypedDict):
    """results.json."""

    meta: Provenance
    tolerances: dict[str, Any]
    systems: dict[str, SystemResult]
    passed: bool


class ReportInput(RunResults, total=False):
    """What the report is rendered from: results.json, with the results of `bench`, `stress` and the chain
    study found beside it (cli/outputs.with_optional_results)."""

    bench: dict[str, Any]
    stress: dict[str, Any]
    chains: dict[str, Any]
    skipped: str


class CheckData(TypedDict, total=False):
    """What `lagrange_xval.check` computed (Result.data): the verdicts before any trajectory."""

    model_checks: ModelChecks
    pointwise: Pointwise
    derivation: Derivation
