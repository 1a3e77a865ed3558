"""Cart-pole: a cart on a horizontal rail and a uniform rod hinged on it.

Contract form: an implicit residual. `residual(p, q, v, a, tau)` returns
M(q) a + C(q, v) v + G(q) - passive(q, v) - tau row by row, in generalized-force units (N for the
x row, N m for the theta row); the harness reads M and the bias forces from it.

Symbols (all read from examples/cart_pole.xml):

    mc                      cart mass, kg
    ccx, ccy, ccz           cart centre of mass in the cart frame, m (it only translates: these
                            move its position and V by a constant, never the dynamics)
    h                       height of the cart frame (the rail) above the world origin, m
    py, pz                  the pole's hinge in the cart frame, (0, py, pz), m
    mp                      pole mass, kg
    l                       pole length, m. The pole is a uniform thin rod: centre of mass at
                            c = l/2 from the hinge, central inertia about the hinge axis
                            I = mp l^2 / 12 (so mp c^2 + I = mp l^2 / 3 about the hinge)
    kx                      viscous friction of the slide, N s/m (MJCF joint damping; the hinge has none)
    g                       gravitational acceleration, m/s^2 (MJCF gravity (0, 0, -g))

Coordinates. World: x along the rail, z up. x is the cart's displacement along world +x (slide
joint `x`); theta is the pole's angle from the upright about the cart's +y axis (hinge `theta`),
positive tipping the top towards +x: the pole frame is R_y(theta) (eq 54), its centre of mass at
(x, py, h + pz) + R_y(theta) (0, 0, c) = (x + c sin th, py, h + pz + c cos th).

Derivation (eqs 66, 72, 74, 75 with the rotation about y):

    v_cp = (x' + c cos th th', 0, -c sin th th'),  omega_p = (0, th', 0)
    T = mc x'^2 / 2 + mp |v_cp|^2 / 2 + I th'^2 / 2
      = (mc + mp) x'^2 / 2 + mp c cos th x' th' + (mp c^2 + I) th'^2 / 2
    V = mc g (h + ccz) + mp g (h + pz + c cos th)      (zero at the world origin's height)

Lagrange's equations, d/dt dT/dq' - dT/dq + dV/dq = tau + passive:

    x:     (mc + mp) x'' + mp c cos th th'' - mp c sin th th'^2 + kx x' - tau_x = 0
    theta: mp c cos th x'' + (mp c^2 + I) th'' - mp g c sin th - tau_theta = 0

(in the theta row, d/dt of mp c cos th x' gives -mp c sin th th' x', which cancels dT/dth).

Inputs. tau = (tau_x, tau_theta): tau_x is the force of the motor `motor_x` times its gear (1) on
the slide; the hinge has no actuator, so tau_theta is an applied joint torque that the harness
leaves at zero (the pole is unactuated). Friction: passive = (-kx x', 0).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from lagrange_xval.forms import NAN, body, hinge, rot_y, stack_vector

DESCRIPTION = (
    "Cart-pole: a cart on a horizontal rail (slide x, force-driven, viscous friction) carrying a uniform "
    "rod on a hinge about y (theta from the upright, unactuated); written as the implicit residual "
    "M a + C v + G - passive - tau, row by row."
)
COORDINATES = ("x", "theta")
JOINTS = ("x", "theta")
BODIES = ("cart", "pole")
# Near upright with a push on the cart: the pole falls and swings under the rail.
INITIAL_STATE = ((0.0, 0.1), (0.5, 0.0))


@dataclass(frozen=True)
class Params:
    mc: float  # kg
    ccx: float  # m
    ccy: float  # m
    ccz: float  # m
    h: float  # m
    py: float  # m
    pz: float  # m
    mp: float  # kg
    l: float  # m  # noqa: E741 - the usual symbol
    kx: float  # N s/m
    g: float  # m/s^2


def parameters(model: Any) -> Params:
    """Reads the parameters from the compiled MJCF (see validate/model/modelview.py for the keys)."""
    cc, pole = model["body/cart/com"], model["body/pole/pos"]
    return Params(
        mc=model["body/cart/mass"],
        ccx=cc[0],
        ccy=cc[1],
        ccz=cc[2],
        h=model["body/cart/pos"][2],
        py=pole[1],
        pz=pole[2],
        mp=model["body/pole/mass"],
        l=2.0 * model["body/pole/com"][2],
        kx=model["joint/x/damping"],
        g=-model["gravity"][2],
    )


def _slide(name: str, *, body: str, axis: Any, damping: float = 0.0) -> dict[str, Any]:
    """The assumptions about one slide joint (no armature, friction loss or spring). Its anchor does
    not matter to a slide (NaN)."""
    return {
        **hinge(name, body=body, axis=axis, pos=(NAN, NAN, NAN), damping=damping),
        f"joint/{name}/type": "slide",
    }


def assumptions(p: Params) -> dict[str, Any]:
    """The compiled model this derivation describes: the cart frame at (0, 0, h) sliding along world x,
    the pole a uniform rod of length l along its body z (centre of mass at l/2, central inertia
    mp l^2 / 12 about y) hinged about the cart's y axis, no body rotated at q = 0, gravity along -z,
    damping on the slide only, a gear-1 motor on x. The cart never rotates (its inertia does not
    enter); the pole turns about y only (only its Iyy enters)."""
    pole_inertia = np.array([[NAN, NAN, NAN], [NAN, p.mp * p.l**2 / 12.0, NAN], [NAN, NAN, NAN]])
    return {
        "gravity": np.array([0.0, 0.0, -p.g]),
        **body(
            "cart", parent="world", mass=p.mc, com=(p.ccx, p.ccy, p.ccz), inertia=np.full((3, 3), NAN), pos=(0, 0, p.h)
        ),
        **body("pole", parent="cart", mass=p.mp, com=(0, 0, p.l / 2.0), inertia=pole_inertia, pos=(0, p.py, p.pz)),
        **_slide("x", body="cart", axis=(1, 0, 0), damping=p.kx),
        **hinge("theta", body="pole", axis=(0, 1, 0)),
        "actuator/motor_x/joint": "x",
        "actuator/motor_x/gear": 1.0,
    }


def residual(p: Params, q: np.ndarray, v: np.ndarray, a: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """M(q) a + C(q, v) v + G(q) - passive(q, v) - tau, the two rows of Lagrange's equations (N, N m)."""
    th = q[..., 1]
    dx, dth = v[..., 0], v[..., 1]
    ddx, ddth = a[..., 0], a[..., 1]
    s, c = np.sin(th), np.cos(th)
    lc = p.l / 2.0  # centre of mass from the hinge
    Ic = p.mp * p.l**2 / 12.0  # central inertia of the rod
    r_x = (p.mc + p.mp) * ddx + p.mp * lc * c * ddth - p.mp * lc * s * dth**2 + p.kx * dx - tau[..., 0]
    r_th = p.mp * lc * c * ddx + (p.mp * lc**2 + Ic) * ddth - p.mp * p.g * lc * s - tau[..., 1]
    return stack_vector([r_x, r_th])


def passive(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Viscous friction on the slide only: (-kx x', 0)."""
    k = np.array([p.kx, 0.0])
    return -k * v + np.zeros(np.broadcast_shapes(np.shape(q), np.shape(v)))


def kinetic_energy(p: Params, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """T = (mc + mp) x'^2 / 2 + mp c cos th x' th' + (mp c^2 + I) th'^2 / 2, c = l/2, I = mp l^2 / 12."""
    c = np.cos(q[..., 1])
    dx, dth = v[..., 0], v[..., 1]
    lc, Ic = p.l / 2.0, p.mp * p.l**2 / 12.0
    return 0.5 * (p.mc + p.mp) * dx**2 + p.mp * lc * c * dx * dth + 0.5 * (p.mp * lc**2 + Ic) * dth**2


def potential_energy(p: Params, q: np.ndarray) -> np.ndarray:
    """V = mc g (h + ccz) + mp g (h + pz + c cos th), zero at the world origin's height (eq 75)."""
    c = np.cos(q[..., 1])
    return p.mc * p.g * (p.h + p.ccz) + p.mp * p.g * (p.h + p.pz + p.l / 2.0 * c) + 0.0 * q[..., 0]


def body_positions(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """Cart: (x + ccx, ccy, h + ccz); pole: (x + c sin th, py, h + pz + c cos th), c = l/2."""
    x, th = q[..., 0], q[..., 1]
    lc = p.l / 2.0
    one = np.ones_like(x)
    cart = stack_vector([x + p.ccx, p.ccy * one, (p.h + p.ccz) * one])
    pole = stack_vector([x + lc * np.sin(th), p.py * one, p.h + p.pz + lc * np.cos(th)])
    return {"cart": cart, "pole": pole}


def body_rotations(p: Params, q: np.ndarray) -> dict[str, np.ndarray]:
    """The cart does not rotate; the pole's frame is R_y(theta) (eq 54)."""
    th = q[..., 1]
    cart = np.broadcast_to(np.eye(3), np.shape(th) + (3, 3)).copy()
    return {"cart": cart, "pole": rot_y(th)}


VARIANTS = ()
