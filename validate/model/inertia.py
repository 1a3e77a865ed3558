"""Defects of a published file's inertias: found, named and repaired in one stated way.

A link's inertia tensor must be positive definite and its principal moments A, B, C must satisfy the
triangle inequality A + B >= C (each one: a rigid body's mass cannot be farther from every axis than
the other two allow). Published URDFs break both; MuJoCo refuses them ("inertia must satisfy A + B >=
C; use 'balanceinertia'", "inertia must have positive eigenvalues"), Pinocchio reads them as written,
and Drake may replace them. The harness states each defect (the link, the inequality, by how much)
and, so that MuJoCo can read the file, gives MuJoCo the tensor its compiler's `balanceinertia` gives:
every principal moment set to their mean (trace / 3, an isotropic tensor), and the same for a tensor
that is not positive definite but whose trace is; a link of mass 0 with a non-zero inertia has the
inertia dropped, as MuJoCo reads it (Pinocchio keeps it, Drake reads such a link as 1 kg). The other
readers read a defective file as written, so their readings of that link differ from MuJoCo's and the
verdict names the defect as the file's, saying who was given which numbers; with
`--balance-inertia` every reader is given the repaired values.

A moving link below MuJoCo's minimum mass or inertia (mjMINVAL: a massless "virtual" link between two
joints, a point mass with zero inertia) is no defect: the URDF is valid, MuJoCo alone cannot compile
it. It is given MuJoCo's boundmass and boundinertia values for every reader (`bound_urdf`), so every
reader sees the same numbers and none differs from another by the floor; the alignments say so.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

TOLERANCE = 1e-12  # relative to the largest moment: MuJoCo's own check allows rounding


def tensor(inertia: ET.Element) -> np.ndarray:
    """The (3, 3) tensor of a URDF <inertia> element (absent entries 0)."""
    get = lambda k: float(inertia.get(k, "0") or 0.0)  # noqa: E731
    xy, xz, yz = get("ixy"), get("ixz"), get("iyz")
    return np.array([[get("ixx"), xy, xz], [xy, get("iyy"), yz], [xz, yz, get("izz")]])


def defect(I: np.ndarray) -> str:
    """What is wrong with the tensor I, or "" (valid, or zero: a massless link)."""
    if not np.any(I):
        return ""
    moments = np.linalg.eigvalsh(I)
    scale = float(np.abs(moments).max())
    shown = ", ".join(f"{m:.4g}" for m in moments)
    if moments[0] <= TOLERANCE * scale:
        return f"inertia not positive definite (principal moments {shown} kg m^2)"
    a, b, c = moments
    if a + b < c - TOLERANCE * scale:
        return f"principal moments violate A + B >= C: {a:.4g} + {b:.4g} < {c:.4g} by {c - a - b:.3g} kg m^2"
    return ""


def repaired(I: np.ndarray) -> np.ndarray | None:
    """MuJoCo's balanceinertia of a defective tensor: trace / 3 on the diagonal (None where the trace is
    not positive: no valid tensor to give)."""
    mean = float(np.trace(I)) / 3.0
    return mean * np.eye(3) if mean > 0 else None


def _mass(link: ET.Element) -> float:
    element = link.find("inertial/mass")
    try:
        return float(element.get("value", "0")) if element is not None else 0.0
    except ValueError:
        return float("nan")  # not a number: the readers say so


def urdf_defects(root: ET.Element) -> list[tuple[str, str, ET.Element]]:
    """(link, what is wrong, its <inertia> element) for every defective link of a URDF tree."""
    out = []
    for link in root.iter("link"):
        inertia = link.find("inertial/inertia")
        if inertia is None:
            continue
        I = tensor(inertia)
        massless = _mass(link) == 0.0 and bool(np.any(I))
        why = f"mass 0 with a non-zero inertia (trace {np.trace(I):.4g} kg m^2)" if massless else defect(I)
        if why:
            out.append((link.get("name", "?"), why, inertia))
    return out


NOISE = 1e-15  # kg m^2: a tensor no entry of which is larger is zero written with rounding noise
MINVAL = 1e-15  # MuJoCo's mjMINVAL: a moving body's mass and principal moments must exceed it
BOUND_MASS, BOUND_INERTIA = 1e-9, 1e-12  # kg, kg m^2: what a moving link below it is given (boundmass, boundinertia)


def _moving_links(root: ET.Element) -> set[str]:
    return {
        str(j.find("child").get("link"))  # type: ignore[union-attr]
        for j in root.iter("joint")
        if j.get("type") not in (None, "fixed") and j.find("child") is not None
    }


def _bounded(root: ET.Element) -> list[str]:
    """Moving links MuJoCo refuses for a mass or a principal moment below MINVAL (a massless "virtual"
    link between two joints, a point mass): given BOUND_MASS and BOUND_INERTIA, as MuJoCo's compiler's
    boundmass and boundinertia would; one line each. A defective tensor (`urdf_defects`) is left to
    `balance_urdf`: it is the file's defect, not a floor."""
    lines = []
    defective = {name for name, _, _ in urdf_defects(root)}
    for link in root.iter("link"):
        if link.get("name") not in _moving_links(root) or link.get("name") in defective:
            continue
        inertial = link.find("inertial")
        mass = _mass(link) if inertial is not None else 0.0
        element = link.find("inertial/inertia")
        moments = np.linalg.eigvalsh(tensor(element)) if element is not None else np.zeros(3)
        if (mass >= MINVAL and moments[0] >= MINVAL) or mass < 0 or moments[0] < -MINVAL * 1e3:
            continue  # valid, or invalid beyond rounding (a negative mass, a negative moment): named elsewhere
        if inertial is None:
            inertial = ET.SubElement(link, "inertial")
        if inertial.find("mass") is None:
            ET.SubElement(inertial, "mass")
        if element is None:
            element = ET.SubElement(inertial, "inertia")
        why = (
            f"mass {mass:g} kg"
            if mass < MINVAL
            else f"principal moments {', '.join(f'{m:.3g}' for m in moments)} kg m^2"
        )
        inertial.find("mass").set("value", repr(max(mass, BOUND_MASS)))  # type: ignore[union-attr]
        _isotropic(element, max(float(np.trace(tensor(element))) / 3.0, BOUND_INERTIA))
        lines.append(
            f"link '{link.get('name')}' moves with {why}, below MuJoCo's minimum {MINVAL:g}; given mass "
            f"{max(mass, BOUND_MASS):g} kg and {float(element.get('ixx', '0')):g} kg m^2 on each axis "
            "(boundmass, boundinertia)"
        )
    return lines


def _isotropic(element: ET.Element, moment: float) -> None:
    for key in ("ixy", "ixz", "iyz"):
        element.set(key, "0")
    for key in ("ixx", "iyy", "izz"):
        element.set(key, repr(moment))


def balance_urdf(text: str) -> tuple[str, list[str]]:
    """The URDF with every defective link's inertia repaired as MuJoCo's balanceinertia would (module
    docstring), and one line per link saying what was wrong and what it was given; the text unchanged
    where nothing is defective. Only MuJoCo is given these (every reader with --balance-inertia)."""
    if "<joint" not in text:
        return text, []
    root = ET.fromstring(text)
    lines = []
    for link, why, element in urdf_defects(root):
        if why.startswith("mass 0"):  # MuJoCo's reading: a massless link has no inertia
            for key in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"):
                element.set(key, "0")
            lines.append(f"link '{link}': {why}; its inertia dropped (MuJoCo's reading of a massless link)")
            continue
        fixed = repaired(tensor(element))
        if fixed is None and float(np.abs(tensor(element)).max()) <= NOISE:
            _isotropic(element, 0.0)  # rounding noise around a zero tensor (1e-35): a point mass
            lines.append(f"link '{link}': {why}; rounding noise around zero, made 0")
            continue
        if fixed is None:
            lines.append(f"link '{link}': {why}; no valid tensor has its trace: read as written")
            continue
        for key in ("ixy", "ixz", "iyz"):
            element.set(key, "0")
        for key in ("ixx", "iyy", "izz"):
            element.set(key, repr(float(fixed[0, 0])))
        lines.append(
            f"link '{link}': {why}; balanced to {fixed[0, 0]:.6g} kg m^2 on each axis (MuJoCo's balanceinertia)"
        )
    return (ET.tostring(root, encoding="unicode"), lines) if lines else (text, [])


def bound_urdf(text: str) -> tuple[str, list[str]]:
    """The URDF with every moving link below MuJoCo's minimum mass or inertia (a massless "virtual" link,
    a point mass: a valid URDF) given boundmass and boundinertia, and one line per link. Not a defect of
    the file but what MuJoCo needs to compile it: every reader is given these same numbers, so that no
    reader's dynamics differ from another's by the floor (System.urdf_text)."""
    if "<joint" not in text:
        return text, []
    root = ET.fromstring(text)
    lines = _bounded(root)
    return (ET.tostring(root, encoding="unicode"), lines) if lines else (text, [])


def repair_urdf(text: str) -> tuple[str, list[str]]:
    """What MuJoCo reads: the defective inertias balanced (`balance_urdf`), then the floors every reader
    gets (`bound_urdf`); the lines of both."""
    balanced, defects = balance_urdf(text)
    bounded, floors = bound_urdf(balanced)
    return bounded, defects + floors
