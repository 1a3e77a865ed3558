"""One system: a model file, its equations module, and the parameters read from the compiled model."""

from __future__ import annotations

import dataclasses
import functools
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict, Unpack

from ..core.errors import HarnessError
from ..core.guard import DEFAULT_TIME_LIMIT, Stopped
from ..core.memo import Memo
from ..handwritten.forms import input_name, normalize
from ..model import bounds, floating, urdf
from ..model.inertia import balance_urdf, bound_urdf
from ..model.modelfile import compile_mjcf, mjcf_text, model_file
from ..model.modelview import ModelView, from_mujoco, names
from ..model.overrides import parse
from .loader import load_module

if TYPE_CHECKING:  # numpy and mujoco are loaded when first used
    import mujoco
    import numpy as np

    from ..forms import FormA, Variant


class Changes(TypedDict, total=False):
    """What `System.derive` may change: any of its fields."""

    name: str
    mjcf: Path
    equations: FormA | None
    overrides: tuple[tuple[str, float], ...]
    locked: tuple[str, ...]
    balance_inertia: bool
    text: str | None


@dataclass(frozen=True)
class System:
    """One system: its MJCF, its equations module and the parameters read from the compiled model."""

    name: str
    mjcf: Path
    equations: FormA | None  # the equations module (form a after normalize), or None for the model alone
    overrides: tuple[tuple[str, float], ...] = ()
    locked: tuple[str, ...] = ()  # URDF joints made fixed (urdf.lock), a named step listed in the alignments
    balance_inertia: bool = False  # every reader given the repaired inertia of a defective link (model/inertia.py)
    # The MJCF text to use instead of the file's (a probe's edited copy); `mjcf` still names the file.
    text: str | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        bounds.check_system_name(self.name)
        if self.equations is not None:  # None: the model alone (`model_only`), no derivation to check
            object.__setattr__(self, "equations", normalize(self.equations))

    def derive(self, **changes: Unpack[Changes]) -> System:
        """A copy with `changes` (overrides, text, equations) and nothing compiled or read yet."""
        return dataclasses.replace(self, **changes)  # cached properties are not copied

    @classmethod
    def model_only(
        cls, model: str | Path, *, name: str | None = None, locked: tuple[str, ...] = (), balance_inertia: bool = False
    ) -> System:
        """The model alone, for the engines and the symbolic source (no derivation): coordinates are
        the model's joints in order, the bodies those the joints move; `locked`: URDF joints made fixed."""
        model = Path(model)
        if not model.is_file():
            raise HarnessError(f"model file not found: {model} (give an MJCF .xml or a URDF .urdf file).")
        system = cls(
            name=name or model.stem, mjcf=model, equations=None, locked=tuple(locked), balance_inertia=balance_inertia
        )
        system.mujoco_model()
        return system

    @classmethod
    def from_files(
        cls,
        model: str | Path,
        equations: str | Path,
        *,
        name: str | None = None,
        locked: tuple[str, ...] = (),
        time_limit: float = DEFAULT_TIME_LIMIT,
        balance_inertia: bool = False,
    ) -> System:
        """A system from any model file (MJCF or URDF) and any equations module file (named after the
        module's file stem unless `name` is given); both are checked before anything is computed.
        `locked`: URDF joints made fixed, a named step listed in the alignments. `time_limit`: seconds
        each call into the module (and its import) may take (validate/core/guard.py).

            >>> from lagrange_xval import System
            >>> from lagrange_xval.core.package import EQUATIONS_DIR, MODELS_DIR
            >>> pendulum = System.from_files(MODELS_DIR / "simple_pendulum.xml", EQUATIONS_DIR / "simple_pendulum.py")
            >>> pendulum.name, pendulum.coordinates, pendulum.nv
            ('simple_pendulum', ('theta',), 1)
        """
        model, equations = Path(model), Path(equations)
        if not model.is_file():
            raise HarnessError(f"model file not found: {model} (give an MJCF .xml or a URDF .urdf file).")
        module = load_module(equations, model=model, time_limit=time_limit)
        system = cls(
            name=name or equations.stem,
            mjcf=model,
            equations=module,
            locked=tuple(locked),
            balance_inertia=balance_inertia,
        )
        system.mujoco_model()  # a model MuJoCo refuses fails here, in one line
        return system

    def with_overrides(self, **values: float) -> System:
        """A copy with parameter overrides, by key (`"body/link1/mass"`) or as keyword arguments with
        `__` for `/` (`body__link1__mass=1.5`); see validate/model/overrides.py for the keys."""

        items = [f"{k.replace('__', '/')}={v!r}" for k, v in values.items()]
        return self.derive(overrides=self.overrides + parse(items))

    @property
    def coordinates(self) -> tuple[str, ...]:
        given = getattr(self.equations, "COORDINATES", None)
        return self.joints if given is None else tuple(given)

    @property
    def model_joints(self) -> tuple[str, ...]:
        """The model's joints, in the model's order."""
        return tuple(names(self.view, "joint", "type"))

    @property
    def joints(self) -> tuple[str, ...]:
        """The joint measuring each coordinate: the module's JOINTS; else its COORDINATES where they
        name the model's joints; else the model's joints in order."""
        given = getattr(self.equations, "JOINTS", None)
        if given is not None:
            return tuple(given)
        named = getattr(self.equations, "COORDINATES", None)
        if named is not None and set(named) <= set(self.model_joints):
            return tuple(named)
        return self.model_joints

    @property
    def joint_map(self) -> np.ndarray | None:
        """A with q_notes = A q_joints, or None where each coordinate is its joint's own angle."""
        A = getattr(self.equations, "JOINT_MAP", None)
        if A is None:
            return None
        import numpy as np

        A = np.asarray(A, dtype=float)
        if A.shape != (self.nv, self.nv) or abs(np.linalg.det(A)) < 1e-12:
            raise HarnessError(f"equations/{self.name}.py: JOINT_MAP must be an invertible {self.nv}x{self.nv} matrix.")
        return A

    @property
    def units(self) -> tuple[str, ...]:
        """The unit of each coordinate: "rad" for hinges, "m" for slides ("mixed" where JOINT_MAP combines
        both in one coordinate); velocities are these per second, inputs N m (hinge) or N (slide)."""
        kinds = [self.view[f"joint/{j}/type"] for j in self.joints]
        A = self.joint_map
        n = range(self.nv)
        rows = [[i] for i in n] if A is None else [[j for j in n if A[i, j]] for i in n]
        out = []
        for row in rows:
            found = {"m" if kinds[j] == "slide" else "rad" for j in row}
            out.append(found.pop() if len(found) == 1 else "mixed")
        return tuple(out)

    @property
    def joint_ranges(self) -> np.ndarray:
        """(n, 2) lower and upper limits of the coordinates' joints as the model states them (a URDF's
        <limit>, an MJCF range), -inf/inf where none; random states are drawn inside them. The limits'
        forces are never compared (they are switched off); a free or ball joint's middle angle stays
        within +-floating.CHART_LIMIT, away from its chart's singularity."""
        import mujoco
        import numpy as np

        out = np.tile([-np.inf, np.inf], (len(self.joints), 1))
        if self.joint_map is not None:  # coordinates mixing joints: no box in these coordinates
            return out
        m = self.mujoco_model()
        for i, j in enumerate(self.joints):
            jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j)
            if jid >= 0 and m.jnt_limited[jid] and m.jnt_range[jid][0] < m.jnt_range[jid][1]:
                out[i] = m.jnt_range[jid]
        if self.model_format != "urdf":  # a free or ball joint's middle angle, away from its chart's singularity
            chart = self._floating.middle
            for i, j in enumerate(self.joints):
                if j in chart:
                    out[i] = np.clip(out[i], -floating.CHART_LIMIT, floating.CHART_LIMIT)
        return out

    @property
    def bodies(self) -> tuple[str, ...]:
        """The bodies whose poses are compared: the module's BODIES; else those its body_positions()
        names; none where it gives no poses; for the model alone, every body a joint moves."""
        if self.equations is not None:
            given = getattr(self.equations, "BODIES", None)
            return tuple(given) if given is not None else self._posed_bodies()
        moved = {self.view[f"joint/{j}/body"] for j in self.joints}
        return tuple(b for b in names(self.view, "body", "mass") if b in moved)

    def _posed_bodies(self) -> tuple[str, ...]:
        """The bodies a module's body_positions() (or body_rotations()) names, read at q = 0."""
        import numpy as np

        from ..handwritten.forms import provided

        for name in ("body_positions", "body_rotations"):
            fn = getattr(self.equations, name, None)
            if fn is not None and provided(fn):
                try:
                    return tuple(fn(self.params, np.zeros(self.nv)))
                except (Exception, Stopped):  # noqa: BLE001 - the user's function: judged where it is called
                    return ()
        return ()

    @property
    def uses(self) -> frozenset[str]:
        """The physics the scene uses, read from the model: gravity, joint damping, actuators."""
        view = self.view
        found = {
            "gravity": any(float(x) != 0.0 for x in view["gravity"]),
            "damping": any(view[f"joint/{j}/damping"] > 0 for j in self.model_joints),
            "actuation": any(k.startswith("actuator/") for k in view),
        }
        return frozenset(k for k, on in found.items() if on)

    @property
    def inputs(self) -> str:
        """ "u" where the derivation takes the actuators' controls, "tau" where a generalized force on
        every coordinate (validate/handwritten/forms.py `input_name`)."""
        return "tau" if self.equations is None else input_name(self.equations)

    @property
    def actuators(self) -> tuple[str, ...]:
        """The model's actuators, in the model's order."""
        return tuple(names(self.view, "actuator", "joint"))

    @property
    def input_matrix(self) -> np.ndarray:
        """B (nv, nu): the generalized force on each coordinate per unit control of each actuator (its gear
        on the coordinate of its joint), so tau = B u."""
        import numpy as np

        if self.joint_map is not None and self.actuators:
            raise HarnessError(f"{self.name}: inputs u with a JOINT_MAP are not supported; take tau instead.")
        B = np.zeros((self.nv, len(self.actuators)))
        for k, name in enumerate(self.actuators):
            joint = self.view[f"actuator/{name}/joint"]
            if joint in self.joints:
                B[self.joints.index(joint), k] = float(self.view[f"actuator/{name}/gear"])
        return B

    @property
    def derivation(self) -> FormA:
        """The equations module in form (a), where a derivation is required; a HarnessError for the
        model alone (`model_only`: no derivation to check)."""
        if self.equations is None:
            raise HarnessError(f"{self.name}: the model alone has no derivation (give an equations module).")
        return self.equations

    @property
    def nv(self) -> int:
        return len(self.coordinates)

    @property
    def description(self) -> str:
        if self.equations is None:
            return f"the model {self.mjcf.name} alone (no derivation)"
        given = getattr(self.equations, "DESCRIPTION", None) or (self.equations.__doc__ or "").strip()
        return " ".join(str(given).split("\n\n")[0].split()) or f"the equations in {self.equations.__name__}"

    @property
    def model_format(self) -> str:
        """ "urdf" or "mjcf": the format of the model file."""
        return "urdf" if self.text is None and self._file()[0] == urdf.ROOT else "mjcf"

    @property
    def reads_urdf(self) -> bool:
        """Whether both engines read the URDF file itself (overrides and probes edit its MJCF form)."""
        return self.model_format == "urdf" and not self.overrides

    def urdf_text(self) -> str:
        """The URDF file's text (only for `reads_urdf` systems), with the `locked` joints made fixed and
        MuJoCo's floors under a point mass or a massless moving link (every reader reads this text)."""
        return self._urdf_read[0]

    @functools.cached_property
    def _urdf_read(self) -> tuple[str, list[str]]:
        """The URDF every reader reads (locked joints fixed, defects balanced with --balance-inertia, and
        MuJoCo's floors under a point mass or a massless link: model/inertia.bound_urdf), and the lines
        saying which links got the floors."""
        text = self._file()[1]
        text = urdf.lock(text, self.locked, self.mjcf.name) if self.locked else text
        text = balance_urdf(text)[0] if self.balance_inertia else text
        return bound_urdf(text)

    @property
    def defects(self) -> list[str]:
        """The file's defective inertias (model/inertia.py), one line per link, with who was given which
        numbers: stated in the verdict as the file's. MuJoCo's floors under a valid file's point mass or
        massless link are no defect (every reader gets them: `alignments`)."""
        if self.model_format != "urdf":
            return []
        lines = balance_urdf(self._file()[1])[1]
        given = (
            "given to every reader (--balance-inertia)"
            if self.balance_inertia
            else "given to MuJoCo, which refuses the tensor as written; Pinocchio reads it as written, Drake as its "
            "parser does (it may replace an invalid inertia)"
        )
        return [f"{line}; {given}" for line in lines]

    @property
    def defective_links(self) -> tuple[str, ...]:
        """The links whose inertia `defects` names: MuJoCo was given other numbers for them than the other
        readers (unless --balance-inertia)."""
        if self.model_format != "urdf" or self.balance_inertia:
            return ()
        return tuple(line.split("'")[1] for line in balance_urdf(self._file()[1])[1])

    @property
    def defective_bodies(self) -> dict[str, str]:
        """MuJoCo's body holding each defective link (the link itself, or the body a fixed joint fuses it
        into), by body: the link's name. A reading of these bodies that differs from MuJoCo's is the
        file's defect (MuJoCo was given other numbers), not a reader's misreading."""
        links = self.defective_links
        if not links:
            return {}
        text = self._file()[1]
        root = ET.fromstring(urdf.lock(text, self.locked, self.mjcf.name) if self.locked else text)
        up = {
            str(j.find("child").get("link")): (str(j.find("parent").get("link")), j.get("type") == "fixed")  # type: ignore[union-attr]
            for j in root.findall("joint")
            if j.find("child") is not None and j.find("parent") is not None
        }
        out: dict[str, str] = {}
        for link in links:
            body = link
            while f"body/{body}/mass" not in self.view and body in up and up[body][1]:
                body = up[body][0]  # fused into its parent by a fixed joint
            out.setdefault(body, link)
        return out

    @property
    def floors(self) -> list[str]:
        """MuJoCo's floors under a valid URDF's point mass or massless moving link, given to every reader
        (model/inertia.bound_urdf), one line per link."""
        return self._urdf_read[1] if self.model_format == "urdf" else []

    def _file(self) -> tuple[str, str]:
        """The model file's format and text, read once."""
        return self._file_read

    @functools.cached_property
    def _floating(self) -> floating.Converted:
        """The MJCF file's free and ball joints as slides and hinges, converted once (model/floating.py)."""
        return floating.convert(self._file_read[1])

    @functools.cached_property
    def _file_read(self) -> tuple[str, str]:
        return model_file(self.mjcf)

    @functools.cached_property
    def memo(self) -> Memo:
        """What is computed from this System and a few arguments (the fast path's generated code), kept
        with it and never shared with a copy (`derive`, `dataclasses.replace`)."""
        return Memo()

    @property
    def alignments(self) -> list[str]:
        """What the harness does so that the engines' readings of a model agree: for an MJCF its free and
        ball joints in one coordinate per degree of freedom (model/floating.py), for a URDF urdf.py's."""
        if self.model_format != "urdf":
            return self._floating.lines
        locked = [f"joint(s) {', '.join(self.locked)} locked at zero (made fixed) in the URDF both engines read"]
        floors = [f"{line}; given to every reader, so all read the same numbers" for line in self._urdf_read[1]]
        return (locked if self.locked else []) + urdf.alignments(self.urdf_text(), self.mjcf.name) + floors

    def mujoco_model(self) -> mujoco.MjModel:
        """The compiled MjModel (compiled once per System)."""
        return self._model

    @property
    def left_out(self) -> list[str]:
        """The constraints of the model (limits, contacts, equality, friction loss) and the passive forces
        only MuJoCo computes, one line per kind: switched off in every comparison (model/scope.py)."""
        return self._compiled[1]

    @functools.cached_property
    def _model(self) -> mujoco.MjModel:
        return self._compiled[0]

    @functools.cached_property
    def _compiled(self) -> tuple[mujoco.MjModel, list[str], int]:
        """The MjModel, compiled, checked for what no source could compare and with its constraints
        switched off; what was left out; and the disable flags as published."""
        from ..model.scope import (  # reads the compiled model with mujoco: loaded when first needed
            refusals,
            unconstrained,
        )

        if self.locked and self.text is None and self.model_format != "urdf":
            raise HarnessError(f"{self.mjcf.name}: --lock takes joints of a URDF model (an MJCF states its own).")
        if self.reads_urdf:
            model = urdf.compile_urdf(self.urdf_text(), self.mjcf.name)
        else:
            model = compile_mjcf(self.mjcf, self.overrides, self.text or self._locked_mjcf())
        refused = refusals(model)  # before any dynamics: what no source could compare
        if refused:
            more = f" (and {len(refused) - 1} more: {'; '.join(refused[1:])})" if len(refused) > 1 else ""
            raise HarnessError(f"{self.mjcf.name}: {refused[0]}{more}.")
        published = int(model.opt.disableflags)
        return model, unconstrained(model), published

    @property
    def published_flags(self) -> int:
        """MuJoCo's disable flags as the model states them, before its constraints were switched off."""
        return self._compiled[2]

    def mjcf_xml(self) -> str:
        """The MJCF text both engines parse, with overrides applied."""
        return mjcf_text(self.mjcf, self.overrides, self.text or self._locked_mjcf())

    def _locked_mjcf(self) -> str | None:
        """A locked URDF's MJCF form, its joints locked (what overrides and probes edit); else None."""
        if not self.locked or self.model_format != "urdf":
            return None
        return urdf.as_mjcf(self.urdf_text(), self.mjcf.name)

    @functools.cached_property
    def view(self) -> ModelView:
        """The compiled model's numbers, read once."""
        return from_mujoco(self.mujoco_model(), self.mjcf.name)

    @functools.cached_property
    def params(self) -> object:
        """The equations module's `parameters(view)` (a dataclass instance, hashable where frozen), checked
        finite, read once."""
        from ..handwritten.reads import dataclass_instance, hashable, numeric_fields

        params = hashable(dataclass_instance(self.derivation.parameters(self.view)))
        bad = [k for k, x in numeric_fields(params).items() if not math.isfinite(x)]
        if bad:
            raise HarnessError(
                f"parameters() returned a non-finite value for {', '.join(bad)}; every parameter must be a "
                "finite number read from the model."
            )
        return params

    @property
    def variants(self) -> tuple[Variant, ...]:
        return tuple(self.derivation.VARIANTS)
