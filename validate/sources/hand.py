"""The hand-derived equations as a source: the equations module, vectorised over states."""

from __future__ import annotations

import numpy as np

from ..core.errors import HarnessError
from ..handwritten.forms import accelerations_only, not_provided_in, written_form, written_function
from ..handwritten.values import real_array
from ..systems import System
from .base import RightHandSide


def solve_or_nan(M: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with M x = b for stacks M (..., n, n), b (..., n); NaN rows where M is singular.

    One batched solve (the happy path); only when it fails (a singular M somewhere) is each state
    solved on its own, so one bad state costs its own row, not the batch. A non-finite M gives NaN
    through LAPACK without an error.
    """
    try:
        return np.linalg.solve(M, b[..., None])[..., 0]
    except np.linalg.LinAlgError:
        pass
    shape = np.broadcast_shapes(M.shape[:-2], b.shape[:-1])
    n = M.shape[-1]
    Ms = np.broadcast_to(M, (*shape, n, n)).reshape(-1, n, n)
    bs = np.broadcast_to(b, (*shape, n)).reshape(-1, n)
    out = np.full(bs.shape, np.nan)
    for i in range(len(bs)):
        try:
            out[i] = np.linalg.solve(Ms[i], bs[i])
        except np.linalg.LinAlgError:
            pass
    return out.reshape(*shape, n)


class HandSource:
    name = "hand"
    traced_rhs = ""  # why the generated one-state code stands aside (the module cannot be traced), if it does

    def __init__(self, system: System) -> None:
        self.system = system
        self.eq = system.derivation
        self.p = system.params

    def rhs(self, tau: np.ndarray) -> RightHandSide:
        """The one-state right-hand side f(t, y) -> [v..., a...] for constant `tau`: the scalar code
        generated from the equations (sources/fastpath.py), no batch overhead; the batched numpy
        equations one state at a time where the module cannot be traced (`traced_rhs` says why)."""
        from .fastpath import scalar_rhs  # sympy: loaded when first asked for

        if self.accelerations_only:  # the generated code is the motion at zero input: use the module itself
            return self._numeric_rhs(np.asarray(tau, dtype=float))
        try:
            fast, tau_list = scalar_rhs(self.system), [float(x) for x in tau]
        except HarnessError as exc:
            self.traced_rhs = str(exc)
            return self._numeric_rhs(np.asarray(tau, dtype=float))
        return lambda t, y: fast(t, y, tau_list)

    def _numeric_rhs(self, tau: np.ndarray) -> RightHandSide:
        n = len(tau)

        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            a = self.forward(np.asarray(y)[None, :n], np.asarray(y)[None, n:], tau[None])[0]
            return np.concatenate([y[n:], a])

        return rhs

    def damped_rhs(self, tau: np.ndarray, h: float) -> RightHandSide | None:
        """As `rhs`, for MuJoCo's Euler step with implicit joint damping: a = (M + h D)^-1 f; None for
        explicit accelerations (form c), whose M is the inverse of d qacc / d tau: solved again with
        h D added, its generated code divides by terms that vanish (the batched path stands in)."""
        from .fastpath import scalar_rhs

        if written_form(self.system.equations) == "c":
            return None
        try:
            fast, tau_list = scalar_rhs(self.system, damped_step=h), [float(x) for x in tau]
        except HarnessError as exc:
            self.traced_rhs = str(exc)
            return None
        return lambda t, y: fast(t, y, tau_list)

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        n = self.system.nv
        return real_array("mass_matrix()", self.eq.mass_matrix(self.p, q), (*np.shape(q)[:-1], n, n))

    def bias(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return real_array("bias()", self.eq.bias(self.p, q, v), np.broadcast_shapes(np.shape(q), np.shape(v)))

    def passive(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return real_array("passive()", self.eq.passive(self.p, q, v), np.broadcast_shapes(np.shape(q), np.shape(v)))

    @property
    def accelerations_only(self) -> bool:
        """Explicit accelerations with inputs u: no M, bias or passive force to compare (forms.py)."""
        return accelerations_only(self.eq)

    def controls(self, tau: np.ndarray) -> np.ndarray:
        """u with B u = tau (tau in the inputs' range: validate/verdict/pointwise.py draws it so)."""
        return np.asarray(tau) @ np.linalg.pinv(self.system.input_matrix).T

    def forward(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """q'' = M^-1 (tau + passive - bias), one batched solve; NaN at states where M(q) is singular
        or not finite (a wrong derivation's finding, not an exception). Explicit accelerations with
        inputs u: the person's qacc at the controls giving tau."""
        if self.accelerations_only:
            with np.errstate(all="ignore"):
                return np.asarray(written_function(self.eq, "qacc")(self.p, q, v, self.controls(tau)), dtype=float)
        passive, bias, m = self.passive_bias_mass(q, v)
        return solve_or_nan(m, tau + passive - bias)

    def passive_bias_mass(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """passive, bias and M at (q, v): in one round trip to the module's worker where it has one."""
        from ..handwritten.proxy import together

        got = together(
            [(self.eq.passive, (self.p, q, v)), (self.eq.bias, (self.p, q, v)), (self.eq.mass_matrix, (self.p, q))]
        )
        if got is None:
            return self.passive(q, v), self.bias(q, v), self.mass_matrix(q)
        n, both = self.system.nv, np.broadcast_shapes(np.shape(q), np.shape(v))
        return (
            real_array("passive()", got[0], both),
            real_array("bias()", got[1], both),
            real_array("mass_matrix()", got[2], (*np.shape(q)[:-1], n, n)),
        )

    def inverse(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """tau = M a + bias - passive."""
        return np.einsum("...ij,...j->...i", self.mass_matrix(q), a) + self.bias(q, v) - self.passive(q, v)

    @property
    def not_provided(self) -> list[str]:
        """The optional functions the derivation leaves out (their quantities are not checked)."""
        return not_provided_in(self.eq)

    def potential(self, q: np.ndarray) -> np.ndarray:
        """V alone (NaN where the derivation does not provide it): a grid's minimum without its T."""
        shape = np.shape(q)[:-1]
        if "potential_energy" in self.not_provided:
            return np.full(shape, np.nan)
        return real_array("potential_energy()", self.eq.potential_energy(self.p, q), shape)

    def energies(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """T and V; NaN where the derivation does not provide them (never compared then)."""
        missing = self.not_provided
        shape = np.broadcast_shapes(np.shape(q), np.shape(v))[:-1]
        nan = np.full(shape, np.nan)
        return (
            nan
            if "kinetic_energy" in missing
            else real_array("kinetic_energy()", self.eq.kinetic_energy(self.p, q, v), shape),
            nan
            if "potential_energy" in missing
            else real_array("potential_energy()", self.eq.potential_energy(self.p, q), shape),
        )

    def evaluate(
        self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, a_ref: np.ndarray | None = None
    ) -> dict[str, np.ndarray]:
        """Every pointwise quantity, vectorised over the states (M computed once). Without `a_ref`
        the inverse dynamics is taken at the source's own accelerations."""
        M, bias, passive = self.mass_matrix(q), self.bias(q, v), self.passive(q, v)
        kin, pot = self.energies(q, v)
        qacc = self.forward(q, v, tau) if self.accelerations_only else solve_or_nan(M, tau + passive - bias)
        out = {
            "M": M,
            "bias": bias,
            "passive": passive,
            "qacc": qacc,
            "tau_inverse": np.einsum("...ij,...j->...i", M, qacc if a_ref is None else a_ref) + bias - passive,
            "T": kin,
            "V": pot,
            "body_positions": self.body_positions(q),
            "body_rotations": self.body_rotations(q),
        }
        missing = self.not_provided  # quantities the derivation leaves out are left out, not compared
        for key, fn in (("T", "kinetic_energy"), ("V", "potential_energy"), ("body_positions", "body_positions")):
            if fn in missing:
                out.pop(key)
        if "body_rotations" in missing:
            out.pop("body_rotations")
        if self.accelerations_only:  # M, the forces and the inverse dynamics are not the person's
            for key in ("M", "bias", "passive", "tau_inverse"):
                out.pop(key)
        return out

    def body_positions(self, q: np.ndarray) -> np.ndarray:
        if "body_positions" in self.not_provided:
            return np.full((*np.shape(q)[:-1], len(self.system.bodies), 3), np.nan)
        pos = self.eq.body_positions(self.p, q)
        shape = (*np.shape(q)[:-1], 3)
        return np.stack([real_array(f"body_positions()[{b!r}]", pos[b], shape) for b in self.system.bodies], axis=-2)

    def body_rotations(self, q: np.ndarray) -> np.ndarray:
        if "body_rotations" in self.not_provided:
            return np.full((*np.shape(q)[:-1], len(self.system.bodies), 3, 3), np.nan)
        rot = self.eq.body_rotations(self.p, q)
        shape = (*np.shape(q)[:-1], 3, 3)
        return np.stack([real_array(f"body_rotations()[{b!r}]", rot[b], shape) for b in self.system.bodies], axis=-3)
