"""Ground truth for the mutation catalogue (tests/mutations.py), independent of the harness's verdicts.

For every catalogued mistake this establishes, from the equations modules alone (original against
mutated, no engine and no judge involved):
  - the substitution applies exactly once, touches only hand-derivation functions, and the mutated
    module imports;
  - at the repository model's own parameters the mistake is invisible (every term equal) exactly
    when the catalogue says `hidden`;
  - at randomly perturbed parameters (every parameter moved by an independent factor) the terms
    that differ are exactly the catalogue's `terms`;
  - a mistake that makes M singular or indefinite really does at some state, and the gimbal with
    the friction sign flipped gains energy without bound.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import pkgutil

import numpy as np
import pytest
from lagrange_xval.systems import load
from scipy.integrate import solve_ivp

from tests import mutations as mu

N_STATES = 200
RTOL = 1e-9  # a term differs if max |mutated - original| > RTOL * the term's max magnitude
PERTURBATION_SEEDS = (11, 12, 13)

IDS = [f"{m.system}:{m.name}" for m in mu.MUTATIONS]


def _systems_on_disk() -> list[str]:
    package = importlib.import_module(mu.PACKAGE)
    return sorted(m.name for m in pkgutil.iter_modules(package.__path__) if not m.name.startswith("_"))


@functools.cache
def _repository(system: str):
    """The repository model's view and parameters, read as the harness reads them."""
    s = load(system)
    return s.view, s.params


@functools.cache
def _mutated(m: mu.Mutation):
    return mu.load_mutated(m)


def _states(nv: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=(N_STATES, nv))
    v = rng.uniform(-10.0, 10.0, size=(N_STATES, nv))
    return q, v


def _factor(rng: np.random.Generator) -> float:
    return float(rng.uniform(0.5, 0.8) if rng.random() < 0.5 else rng.uniform(1.25, 2.0))


def _perturbed_params(p, rng: np.random.Generator):
    """Every field of the Params dataclass times its own factor in [0.5, 0.8] or [1.25, 2]."""
    return dataclasses.replace(p, **{f.name: getattr(p, f.name) * _factor(rng) for f in dataclasses.fields(p)})


def _perturbed_view(view, rng: np.random.Generator) -> dict:
    """The model view with every number (every array element) times its own factor."""
    out = {}
    for key in sorted(view):
        value = view[key]
        if isinstance(value, float | int) and not isinstance(value, bool):
            out[key] = float(value) * _factor(rng)
        elif isinstance(value, np.ndarray) and value.dtype.kind == "f":
            out[key] = value * np.array([_factor(rng) for _ in range(value.size)]).reshape(value.shape)
        else:
            out[key] = value
    return out


def _differs(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        return True
    if not (np.all(np.isfinite(b)) and np.all(np.isfinite(a))):
        return not np.array_equal(a, b, equal_nan=True)
    scale = max(float(np.max(np.abs(a), initial=0.0)), float(np.max(np.abs(b), initial=0.0)))
    return float(np.max(np.abs(a - b), initial=0.0)) > RTOL * scale


def differing_terms(original, mutated, p_orig, p_mut, q, v) -> set[str]:
    """The terms (and "parameters") in which the mutated module differs from the original."""
    out = set()
    for f in dataclasses.fields(p_orig):
        if _differs(getattr(p_orig, f.name), getattr(p_mut, f.name)):
            out.add("parameters")
    a = mu.term_values(original, p_orig, q, v)
    b = mu.term_values(mutated, p_mut, q, v)
    out |= {k for k in a if _differs(a[k], b[k])}
    return out


def _edits_parameters(m: mu.Mutation) -> bool:
    return "parameters" in mu.changed_functions(m)


def _at_repository(m: mu.Mutation) -> set[str]:
    original, mutated = mu.original(m.system), _mutated(m)
    view, _ = _repository(m.system)
    q, v = _states(len(original.COORDINATES))
    return differing_terms(original, mutated, original.parameters(view), mutated.parameters(view), q, v)


def _at_perturbed(m: mu.Mutation, seed: int) -> set[str]:
    original, mutated = mu.original(m.system), _mutated(m)
    view, params = _repository(m.system)
    rng = np.random.default_rng(seed)
    q, v = _states(len(original.COORDINATES), seed)
    if _edits_parameters(m):
        # The mistake is in reading the model: both modules read the same perturbed model.
        pview = _perturbed_view(view, rng)
        return differing_terms(original, mutated, original.parameters(pview), mutated.parameters(pview), q, v)
    p = _perturbed_params(params, rng)
    return differing_terms(original, mutated, p, p, q, v)


# --- the catalogue's shape ---------------------------------------------------------------------


def test_every_system_has_six_to_ten_mutations():
    on_disk = _systems_on_disk()
    assert on_disk, "no equations modules found"
    counts = {s: sum(m.system == s for m in mu.MUTATIONS) for s in on_disk}
    assert all(6 <= n <= 10 for n in counts.values()), counts
    assert {m.system for m in mu.MUTATIONS} <= set(on_disk)


def test_names_terms_and_kinds_are_well_formed():
    keys = [(m.system, m.name) for m in mu.MUTATIONS]
    assert len(keys) == len(set(keys)), "duplicate names"
    assert len({(m.system, m.old, m.new) for m in mu.MUTATIONS}) == len(mu.MUTATIONS), "duplicate substitutions"
    for m in mu.MUTATIONS:
        assert m.terms and m.terms <= mu.TERMS, m
        assert m.kinds <= mu.KINDS, m
        assert m.old != m.new, m


def test_every_kind_of_mistake_is_covered():
    covered = set().union(*(m.kinds for m in mu.MUTATIONS))
    assert covered == set(mu.KINDS), sorted(set(mu.KINDS) - covered)
    assert any(m.hidden for m in mu.MUTATIONS) and any(not m.hidden for m in mu.MUTATIONS)


# --- each mutation ------------------------------------------------------------------------------


@pytest.mark.parametrize("m", mu.MUTATIONS, ids=IDS)
def test_old_occurs_exactly_once(m):
    assert mu.source(m.system).count(m.old) == 1


@pytest.mark.parametrize("m", mu.MUTATIONS, ids=IDS)
def test_only_hand_derivation_functions_change(m):
    changed = mu.changed_functions(m)
    assert changed, "the substitution changes no code"
    assert changed <= mu.HAND_FUNCTIONS, changed
    assert ("parameters" in changed) == ("parameters" in m.terms)


@pytest.mark.parametrize("m", mu.MUTATIONS, ids=IDS)
def test_mutated_module_imports_and_differs(m):
    mutated = _mutated(m)
    assert mutated.__name__.startswith(f"{mu.PACKAGE}._mutated_{m.system}_")
    assert mutated is not mu.original(m.system)
    assert mu.mutated_source(m) != mu.source(m.system)
    assert _at_perturbed(m, PERTURBATION_SEEDS[0]), "no term differs from the original"


@pytest.mark.parametrize("m", mu.MUTATIONS, ids=IDS)
def test_hidden_iff_invisible_at_the_repository_parameters(m):
    differing = _at_repository(m)
    if m.hidden:
        assert differing == set(), f"declared hidden, but differs in {sorted(differing)}"
    else:
        assert differing, "declared visible, but every term equals the original's"
        assert differing <= m.terms, sorted(differing - m.terms)


@pytest.mark.parametrize("seed", PERTURBATION_SEEDS)
@pytest.mark.parametrize("m", mu.MUTATIONS, ids=IDS)
def test_terms_are_exactly_those_that_differ_at_perturbed_parameters(m, seed):
    assert _at_perturbed(m, seed) == set(m.terms)


def _with_grid(q: np.ndarray) -> np.ndarray:
    """The random states plus a 5-degree grid over [-pi, pi]^n (it contains 0 and +-pi exactly)."""
    axis = np.linspace(-np.pi, np.pi, 73)
    grid = np.stack(np.meshgrid(*[axis] * q.shape[-1], indexing="ij"), axis=-1).reshape(-1, q.shape[-1])
    return np.concatenate([q, grid])


def _smallest_relative_eigenvalue(module, p, q) -> float:
    eig = np.linalg.eigvalsh(module.mass_matrix(p, q))
    return float(np.min(eig[..., 0] / np.max(np.abs(eig), axis=-1)))


SINGULAR = 1e-12  # M counts as singular where its smallest eigenvalue is below this, relative to the largest


@pytest.mark.parametrize(
    "m", [m for m in mu.MUTATIONS if "mass matrix" in m.terms], ids=lambda m: f"{m.system}:{m.name}"
)
def test_singular_or_indefinite_mass_matrix_really_is(m):
    """At the repository's parameters: M singular or indefinite at some state iff the catalogue says so."""
    original, mutated = mu.original(m.system), _mutated(m)
    view, _ = _repository(m.system)
    q = _with_grid(_states(len(original.COORDINATES))[0])
    assert _smallest_relative_eigenvalue(original, original.parameters(view), q) > SINGULAR
    smallest = _smallest_relative_eigenvalue(mutated, mutated.parameters(view), q)
    assert (smallest < SINGULAR) == ("M singular or indefinite" in m.kinds), smallest


def test_the_catalogue_has_a_friction_sign_mutation_for_each_damped_system():
    damped = {s for s in _systems_on_disk() if "damping" in load(s).uses}
    assert damped == {m.system for m in mu.MUTATIONS if "friction sign" in m.kinds}


@pytest.mark.parametrize(
    "m", [m for m in mu.MUTATIONS if "friction sign" in m.kinds], ids=lambda m: f"{m.system}:{m.name}"
)
def test_friction_with_the_wrong_sign_feeds_energy_in(m):
    """Unforced, the original loses kinetic energy to friction; the mutated one gains it, exponentially."""
    original, mutated = mu.original(m.system), _mutated(m)
    _, p = _repository(m.system)
    q0, v0 = (np.asarray(x, dtype=float) for x in original.INITIAL_STATE)
    n = len(q0)

    def energy_after(module, t_end: float) -> tuple[float, float]:
        def rhs(t, y):
            q, v = y[:n], y[n:]
            a = np.linalg.solve(module.mass_matrix(p, q), module.passive(p, q, v) - module.bias(p, q, v))
            return np.concatenate([v, a])

        sol = solve_ivp(rhs, (0.0, t_end), np.concatenate([q0, v0]), rtol=1e-9, atol=1e-12)
        assert sol.success, sol.message
        y = sol.y[:, -1]
        return float(module.kinetic_energy(p, q0, v0)), float(module.kinetic_energy(p, y[:n], y[n:]))

    t0, t1 = energy_after(original, 3.0)
    assert t1 < t0
    t0, t1 = energy_after(mutated, 3.0)
    assert t1 > 100 * t0


# --- the checks above can fail -----------------------------------------------------------------


def test_the_ground_truth_rejects_wrong_labels():
    m = next(m for m in mu.MUTATIONS if m.system == "double_pendulum_point" and m.name == "m1 for m2 in M22")
    assert _at_repository(m) == set()
    assert _at_perturbed(m, PERTURBATION_SEEDS[0]) == {"mass matrix", "kinetic energy"}
    # Mislabelled: kinetic energy left out, or declared visible.
    assert _at_perturbed(m, PERTURBATION_SEEDS[0]) != {"mass matrix"}
    visible = next(
        m for m in mu.MUTATIONS if m.system == "double_pendulum_point" and m.name == "lost 2 in M11 cos term"
    )
    assert _at_repository(visible) == {"mass matrix", "kinetic energy"}
    # A substitution that changes nothing numerically differs nowhere.
    noop = mu.Mutation(
        system="gimbal",
        name="no-op reassociation",
        old="d = p.I2xx - p.I2zz",
        new="d = -p.I2zz + p.I2xx",
        terms=frozenset({"velocity"}),
        hidden=True,
    )
    assert _at_perturbed(noop, PERTURBATION_SEEDS[0]) == set()


def test_a_substitution_that_does_not_apply_is_refused():
    bad = dataclasses.replace(mu.MUTATIONS[0], old="this text is not in the module")
    with pytest.raises(ValueError, match="occurs 0 times"):
        mu.load_mutated(bad)
