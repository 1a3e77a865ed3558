"""Inputs a person controls cannot exhaust the harness or forge its output: the text form's expressions
are bounded (validate/handwritten/expression.py), names are data, cache entries are verified before they are
inflated, models are refused above a stated size, and what is shown of a person's text is escaped and cut
(validate/core/errors.py `shown`)."""

from __future__ import annotations

import io
import json
import re
import shutil
import tracemalloc
import types
import zipfile
from pathlib import Path

import lagrange_xval as lx
import numpy as np
import pytest
from lagrange_xval.core import cache
from lagrange_xval.core.errors import HarnessError, escaped, shown
from lagrange_xval.handwritten import textform
from lagrange_xval.systems import model_view

ROOT = Path(__file__).resolve().parents[3]
V = "mc*g*(h + ccz) + mp*g*(h + pz + lc*cos(theta))"
TOML = f'''
T = "(mc + mp)/2*dx^2 + mp*lc*cos(theta)*dx*dtheta + (mp*lc^2 + I)/2*dtheta^2"
V = "{V}"
[symbols]
mc = "body/cart/mass"
mp = "body/pole/mass"
lc = "body/pole/com[2]"
I = "body/pole/inertia[1][1]"
g = "-gravity[2]"
h = "body/cart/pos[2]"
ccz = "body/cart/com[2]"
pz = "body/pole/pos[2]"
'''


def _text_system(folder: Path, old: str = "", new: str = "") -> lx.System:
    """The cart-pole of examples/ with its energies as text, `old` replaced by `new` in the file."""
    shutil.copy(ROOT / "examples/cart_pole.xml", folder / "model.xml")
    assert not old or TOML.count(old) == 1, old
    (folder / "cp.toml").write_text(TOML.replace(old, new) if old else TOML)
    return lx.System.from_files(folder / "model.xml", folder / "cp.toml")


def _module(folder: Path, old: str = "", new: str = "") -> types.ModuleType:
    """The text form's module (form d, before the harness wraps it) of the file `_text_system` writes."""
    shutil.copy(ROOT / "examples/cart_pole.xml", folder / "model.xml")
    (folder / "cp.toml").write_text(TOML.replace(old, new) if old else TOML)
    return textform.module_from_file(folder / "cp.toml", model_view(folder / "model.xml"))


# ---- the text form's expressions ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("bomb", "message"),
    [
        ("9^9^9", r"V is not finite: '9\^9\^9' is about 10\^3.7e\+08, beyond double precision"),
        ("2^2^2^2^2^2^2", r"V is not finite: '2\^2\^2\^2\^2' is about 10\^1.97e\+04"),
        ("mc/0", r"V divides by zero: 'mc/0' divides by '0'"),
        ("mc/(h - h)", r"V divides by zero: 'mc/\(h - h\)' divides by '\(h - h\)'"),
        ("0^-1*mc", r"V divides by zero: '0\^-1' is zero to a negative power"),
        ("log(0)*mc", r"V is not finite: 'log\(0\)' is complex infinity"),
        ("sqrt(-1)*mc", r"V is not real: 'sqrt\(-1\)' is I"),
        ("1e400*mc", r"'1e400' is not a double \(\|x\| from 5e-324 to 1.8e308\)"),
        ("1e-400*mc", r"'1e-400' is not a double"),
        ("mc^(10^300)", r"V is not finite: 'mc\^\(10\^300\)' raises to a power of 1e\+300; an exponent is at most"),
        ("1e200*1e200*mc", r"V is not finite: '1e200\*1e200\*mc' is beyond double precision"),
        ("(" * 101 + "mc" + ")" * 101, r"nests parentheses, calls and exponents deeper than 100 levels"),
        ("mc" + "^mc" * 101, r"deeper than 100 levels"),
        ("h" + "+h" * 50_001, r"has more than 100,000 numbers, names and operations"),
        ("mc" + " " * 200_000, r"has 200,002 characters; at most 200,000"),
    ],
    ids=[
        "9^9^9",
        "2^2^...",
        "m/0",
        "m/(h-h)",
        "0^-1",
        "log0",
        "sqrt-1",
        "1e400",
        "1e-400",
        "m^1e300",
        "overflow",
        "depth",
        "powers",
        "terms",
        "size",
    ],
)
def test_an_expression_bomb_is_one_line_naming_it(tmp_path, bomb, message):
    """What would compute a huge integer, recurse past Python's limit or is not finite is refused in one
    line naming the part, before sympy or numpy meet it."""
    with pytest.raises(HarnessError, match=message) as caught:
        _text_system(tmp_path, V, bomb)
    text = str(caught.value)
    assert "\n" not in text and len(text) < 1500, text[:200]


def test_a_hundred_thousand_signs_are_one_sign(tmp_path):
    """100,000 unary minus signs (an even number) read as none: a loop, not a recursion."""
    module = _module(tmp_path, f'V = "{V}"', f'V = "{"-" * 100_000}({V})"')
    plain = _module(tmp_path / "plain" if (tmp_path / "plain").mkdir() is None else tmp_path)
    assert module.EXPRESSIONS["V"] == plain.EXPRESSIONS["V"]


def test_a_3000_term_potential_works(tmp_path):
    """A realistic V of 3,000 distinct terms (about 120,000 characters) is read, compiled and evaluated;
    its value is the model's V plus the added terms computed apart in numpy."""
    extra = [f"{k}e-6*mp*g*lc*cos({k}*theta)" for k in range(1, 3000)]
    module = _module(tmp_path, f'V = "{V}"', f'V = "{" + ".join([V, *extra])}"')
    plain = _module(tmp_path / "plain" if (tmp_path / "plain").mkdir() is None else tmp_path)
    view = model_view(tmp_path / "model.xml")
    p = module.parameters(view)
    q = np.array([0.3, 0.7])
    added = sum(k * 1e-6 * p.mp * p.g * p.lc * np.cos(k * q[1]) for k in range(1, 3000))
    assert len(module.EXPRESSIONS["V"].args) >= 3000
    assert np.isclose(module.potential_energy(p, q), plain.potential_energy(p, q) + added, rtol=1e-12, atol=0)


def test_the_micro_sign_is_mu(tmp_path):
    """A symbol declared with the micro sign (U+00B5) is the Greek mu (U+03BC) the expressions write: NFKC."""
    micro, mu = "\u00b5", "\u03bc"
    text = TOML.replace("*g*", f"*{mu}*").replace('g = "-gravity[2]"', f'"{micro}" = "-gravity[2]"')
    module = _module(tmp_path, TOML, text)
    plain = _module(tmp_path / "plain" if (tmp_path / "plain").mkdir() is None else tmp_path)
    view = model_view(tmp_path / "model.xml")
    q = np.array([0.3, 0.7])
    assert mu in module.Params.__dataclass_fields__
    assert module.potential_energy(module.parameters(view), q) == plain.potential_energy(plain.parameters(view), q)


def test_two_spellings_of_one_name_are_named_together(tmp_path):
    """l and the script l (U+2113) both declared read as one name: one message naming both spellings."""
    script = "\u2113"
    with pytest.raises(HarnessError, match=f"'lc' and '{script}c' are one name") as caught:
        _module(tmp_path, 'lc = "body/pole/com[2]"', f'lc = "body/pole/com[2]"\n"{script}c" = "body/pole/com[2]"')
    assert "\n" not in str(caught.value)


# ---- cache entries: the signed header first --------------------------------------------------------


def _bloated(path: Path, claim: tuple[int, ...], *, resign: bool) -> None:
    """The entry at `path` with array `q` replaced by a deflated member whose .npy header claims `claim`
    float64s (1.5 GiB) over a few MB of zeros; `resign`: the manifest says so too, signed again."""
    with np.load(path) as z:
        header = json.loads(str(z[cache.HEADER]))
    if resign:
        header["arrays"]["q"] = {"dtype": "<f8", "shape": list(claim), "sha256": "0" * 64}
        header["hmac"] = cache._signature(header)
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(buffer, {"descr": "<f8", "fortran_order": False, "shape": claim})
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr(f"{cache.HEADER}.npy", _npy(np.array(json.dumps(header))))
        z.writestr("q.npy", buffer.getvalue() + bytes(8 * 2**20))


def _npy(a: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, a)
    return buffer.getvalue()


@pytest.mark.parametrize(
    ("resign", "why"),
    [(False, "array q is <f8 \\[201326592\\], signed as <f8 \\[3\\]"), (True, "would take 1,610,612,752 bytes")],
    ids=["member-claims", "signed-claim"],
)
def test_a_small_entry_claiming_gigabytes_is_refused_unread(tmp_path, capsys, resign, why):
    """A few-MB entry whose array claims 1.5 GiB is refused on one warning line from its headers alone:
    the signed manifest states every array's shape, and no array is read that differs from it or that
    would pass MAX_ENTRY_BYTES."""
    path = tmp_path / "x.npz"
    assert cache.store(path, "k", {"q": np.arange(3.0), "t": np.arange(2.0)}, {"n": 1})
    _bloated(path, (3 * 2**26,), resign=resign)
    assert path.stat().st_size < 2**20
    tracemalloc.start()
    try:
        assert cache.load(path, "k") is None
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    err = capsys.readouterr().err
    assert peak < 2**20, f"{peak:,} bytes allocated reading a refused entry"
    assert err.count("\n") == 1 and re.search(why, err), err


def test_a_signed_entry_reads_back_whole(tmp_path):
    """What `store` writes, `load` returns: the arrays bit for bit and the info."""
    arrays = {"q": np.arange(12.0).reshape(3, 4), "i": np.arange(5), "f": np.asfortranarray(np.eye(3))}
    assert cache.store(tmp_path / "x.npz", "k", arrays, {"n": 1})
    loaded, info = cache.load(tmp_path / "x.npz", "k")
    assert info == {"n": 1} and sorted(loaded) == sorted(arrays)
    for name, a in arrays.items():
        assert loaded[name].dtype == a.dtype and np.array_equal(loaded[name], a)


# ---- the user's cache folder -------------------------------------------------------------------------


def test_a_relative_xdg_cache_home_is_ignored(tmp_path, monkeypatch):
    """XDG says a relative XDG_CACHE_HOME is ignored: the cache and its key go under $HOME/.cache, and
    `derive` (which caches in the user's folder) creates nothing in the working directory."""
    from lagrange_xval.cli import main
    from lagrange_xval.core.cachedir import user_folder

    work, home = tmp_path / "work", tmp_path / "home"
    work.mkdir()
    monkeypatch.chdir(work)
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/cache")
    monkeypatch.delenv(cache.CACHE_ENV, raising=False)
    assert user_folder() == home / ".cache" / "lagrange-xval"
    assert cache.key_file() == home / ".cache" / "lagrange-xval" / "key"
    assert main(["derive", "simple_pendulum"]) == 0
    assert list(work.iterdir()) == []
    assert (home / ".cache" / "lagrange-xval" / "derive").is_dir()


# ---- a person's text is data ---------------------------------------------------------------------------


def test_shown_escapes_control_characters_and_cuts():
    """Every C0/C1 control character, DEL and the bidirectional overrides are written as repr writes them;
    past the limit the text is cut, saying how much was left out."""
    text = "a\nverdict: x: pass\r\x1b[31m\x00\x7f\x9b\u2028\u202e" + "y" * 500
    out = shown(text)
    assert out.startswith("a\\nverdict: x: pass\\r\\x1b[31m\\x00\\x7f\\x9b\\u2028\\u202e")
    assert out.endswith(f"... ({len(escaped(text)) - 300} more characters)")
    assert all(c.isprintable() for c in out)
    assert escaped("µ/é θ") == "µ/é θ"  # printable Unicode is kept


RAISES = """
from dataclasses import dataclass
import numpy as np

@dataclass(frozen=True)
class Params:
    m: float
    l: float
    g: float
    I: float

def parameters(model):
    return Params(model["body/link/mass"], -model["body/link/com"][1], -model["gravity"][1],
                  model["body/link/inertia"][2, 2])

def mass_matrix(p, q):
    raise ValueError("boom\\nverdict: mine: pass: forged\\x1b[2J" + "y" * 1_000_000)

def bias(p, q, v):
    return (p.m * p.g * p.l * np.sin(q[..., 0]) + 0 * v[..., 0])[..., None]
"""


def test_a_module_message_cannot_forge_a_verdict_line(tmp_path, capsys):
    """A 1 MB exception message with a newline, a `verdict:` line and an escape sequence: `check` prints
    one verdict line (its own), escaped and cut; `--json` escaped too, and says how much was cut."""
    from lagrange_xval.cli import main
    from lagrange_xval.core.errors import LINE_CHARS

    shutil.copy(ROOT / "models/simple_pendulum.xml", tmp_path / "sp.xml")
    (tmp_path / "sp.py").write_text(RAISES)
    argv = ["check", "--model", str(tmp_path / "sp.xml"), "--equations", str(tmp_path / "sp.py")]
    assert main([*argv, "--states", "20", "--probes", "1"]) == 1
    out = capsys.readouterr().out.splitlines()
    verdicts = [line for line in out if line.startswith("verdict:")]
    assert len(verdicts) == 1 and verdicts[0] == out[-1], verdicts
    assert "mass_matrix() raised ValueError: boom\\nverdict: mine" in out[-1] and "\x1b" not in "".join(out)
    assert max(map(len, out)) < LINE_CHARS + 40
    assert main([*argv, "--states", "20", "--probes", "1", "--json"]) == 1
    statement = json.loads(capsys.readouterr().out)["verdict"]["statement"]
    # as the module's worker carries it back (validate/handwritten/child.py): escaped, no control character
    # crosses the process boundary, and a message this long is cut, saying how much more there was
    assert "boom\\nverdict: mine: pass: forged" in statement and "\x1b" not in statement
    assert re.search(r"\(\d+ more characters\)", statement), statement[-200:]


def test_an_import_error_is_one_escaped_line(tmp_path, capsys):
    """A module whose import raises a 100 kB message of many lines and escape codes: one error line, the
    message escaped and cut to a few hundred characters, status 2."""
    from lagrange_xval.cli import main

    shutil.copy(ROOT / "models/simple_pendulum.xml", tmp_path / "sp.xml")
    (tmp_path / "sp.py").write_text('raise RuntimeError("a\\nverdict: sp: pass\\x1b]0;title\\x07" + "z" * 100_000)\n')
    assert main(["check", "--model", str(tmp_path / "sp.xml"), "--equations", str(tmp_path / "sp.py")]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("lagrange-xval: error: "), lines[:3]
    assert "RuntimeError: a\\nverdict: sp: pass\\x1b]0;title\\x07zzz" in lines[0]
    assert lines[0].endswith("more characters)") and len(lines[0]) < 600  # the message cut to 300


# ---- models: size and numbers, before any engine works -------------------------------------------------

FLAT = (
    '<body name="b{i}" pos="{x} 0 0"><joint name="j{i}" type="hinge" axis="0 0 1"/>'
    '<inertial pos="0 0 -0.1" mass="1" diaginertia="0.01 0.01 0.01"/></body>'
)


def _flat(n: int) -> str:
    return "<mujoco><worldbody>" + "".join(FLAT.format(i=i, x=0.01 * i) for i in range(n)) + "</worldbody></mujoco>"


REPLICATED = (
    '<mujoco><worldbody><replicate count="100" offset="0.1 0 0"><replicate count="100" offset="0 0.1 0">'
    + FLAT.format(i=0, x=0)
    + "</replicate></replicate></worldbody></mujoco>"
)


@pytest.mark.parametrize("text", [_flat(10_000), REPLICATED], ids=["10000-bodies", "replicate-100x100"])
def test_a_huge_model_is_refused_before_it_is_compiled(tmp_path, capsys, monkeypatch, text):
    """10,000 joints (written out, or two nested <replicate count=100>) are one error line naming the
    limits, status 2, and MuJoCo never compiles the model."""
    import mujoco
    from lagrange_xval.cli import main

    def never(*args, **kwargs):
        raise AssertionError("compiled")

    monkeypatch.setattr(mujoco.MjModel, "from_xml_string", never)
    (tmp_path / "big.xml").write_text(text)
    assert main(["check", "--model", str(tmp_path / "big.xml")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "10,000 joints and 10,000 bodies; a model may have at most 500 joints" in err[0], err


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('gravity="0 -9.81 0"', 'gravity="0 nan 0"', r"gravity \(0 nan 0\) is not finite"),
        ('axis="0 0 1" pos', 'axis="0 0 inf" pos', r"joint 'theta' axis \(0 0 nan\) is not finite"),
        ('mass="1" diag', 'mass="1e308" diag', r"body 'link' mass \(1e\+308\) exceeds 1e\+100"),
    ],
    ids=["gravity-nan", "axis-inf", "mass-1e308"],
)
@pytest.mark.parametrize("command", ["check", "audit"])
def test_a_number_that_is_not_finite_is_named(tmp_path, capsys, old, new, message, command):
    """Non-finite gravity, an infinite axis, a mass whose products overflow: one error line naming the
    field and the element, status 2 (not status 1 with numpy's overflow warnings and NaN differences)."""
    from lagrange_xval.cli import main

    text = (ROOT / "models/simple_pendulum.xml").read_text()
    assert text.count(old) == 1
    (tmp_path / "sp.xml").write_text(text.replace(old, new))
    shutil.copy(ROOT / "equations/simple_pendulum.py", tmp_path / "sp.py")
    argv = ["check", "--model", str(tmp_path / "sp.xml"), "--equations", str(tmp_path / "sp.py")]
    assert main(argv if command == "check" else ["audit", str(tmp_path / "sp.xml")]) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and re.search(message, lines[0]), captured.err[-2000:]


BOMB = (
    '<?xml version="1.0"?>\n<!DOCTYPE mujoco [<!ENTITY a "aaaaaaaaaa">'
    + "".join(f'<!ENTITY {c} "{("&" + p + ";") * 10}">' for p, c in zip("abcdefg", "bcdefgh", strict=True))
    + "]>\n"
)
XXE = '<?xml version="1.0"?>\n<!DOCTYPE mujoco [<!ENTITY x SYSTEM "file:///etc/hostname">]>\n'


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("malformed", "not well-formed XML"),
        ("entity-bomb", "declares <!DOCTYPE ...>; a model needs no DOCTYPE or entities"),
        ("xxe", "declares <!DOCTYPE ...>"),
        ("missing-include", r'<include file="/[^"]*/gone.xml">: no such file'),
    ],
)
def test_a_bad_model_in_a_systems_folder_is_one_line(tmp_path, capsys, case, message):
    """`run --systems DIR` of a folder whose model is malformed, holds an entity bomb or an external
    entity, or includes a file that does not exist: status 2, one error line naming
    the cause, nothing written."""
    from lagrange_xval.cli import main

    text = (ROOT / "models/simple_pendulum.xml").read_text()
    head = text.index("<mujoco")
    folder = tmp_path / "systems"
    folder.mkdir()
    (tmp_path / "inc.xml").write_text('<mujoco><option timestep="0.002"/></mujoco>')
    body = {
        "malformed": text[:300],
        "entity-bomb": BOMB + text[head:].replace("<mujoco", '<mujoco model="&h;"', 1),
        "xxe": XXE + text[head:].replace("<mujoco", '<mujoco model="&x;"', 1),
        "missing-include": text.replace("<worldbody>", f'<include file="{tmp_path / "gone.xml"}"/><worldbody>'),
    }[case]
    (folder / "x.xml").write_text(body)
    shutil.copy(ROOT / "equations/simple_pendulum.py", folder / "x.py")
    out = tmp_path / "out"
    assert main(["run", "--systems", str(folder), "--out", str(out), "--no-replay"]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and re.search(message, lines[0]), lines[-3:]
    assert lines[0].startswith("lagrange-xval: error: x.xml: ") and not out.exists()


# ---- names with /, :, spaces and Unicode --------------------------------------------------------------

NAMES = {'"link1"': '"upper arm:1"', '"link2"': '"fore/arm"', 'name="theta"': 'name="arm/theta"'}
NAMES_MODULE = {"link1": "upper arm:1", "link2": "fore/arm"}


def _named_system(folder: Path) -> tuple[Path, Path]:
    """The double pendulum of the notes with a body `upper arm:1`, a body `fore/arm`, a joint `arm/theta`
    and a joint `φ elbow`: its model and its hand derivation, the keys renamed."""
    text = (ROOT / "models/double_pendulum_point.xml").read_text()
    for old, new in {**NAMES, 'name="phi"': 'name="\u03c6 elbow"'}.items():
        text = text.replace(old, new)
    module = (ROOT / "equations/double_pendulum_point.py").read_text()
    for old, new in NAMES_MODULE.items():
        module = module.replace(old, new)
    module = module.replace('JOINTS = ("theta", "phi")', 'JOINTS = ("arm/theta", "\u03c6 elbow")')
    module = module.replace('hinge("theta"', 'hinge("arm/theta"').replace('hinge("phi"', 'hinge("\u03c6 elbow"')
    (folder / "names.xml").write_text(text)
    (folder / "names.py").write_text(module)
    return folder / "names.xml", folder / "names.py"


def test_key_parts_keep_a_name_whole():
    """The kind is a key's first part and the field its last: whatever the name holds stays whole."""
    from lagrange_xval.model.modelview import key_parts, names

    assert key_parts("joint/arm/theta/damping") == ("joint", "arm/theta", "damping")
    assert key_parts("body/upper arm:1/com") == ("body", "upper arm:1", "com")
    assert key_parts("gravity") is None and key_parts("scale/mass") is None
    keys = ["gravity", "joint/a/b/type", "joint/a/b/axis", "joint/\u03c6 c/type", "body/a/b/mass"]
    assert names(keys, "joint", "type") == ["a/b", "\u03c6 c"]


def test_names_with_slashes_colons_spaces_and_unicode_pass(tmp_path):
    """A derivation of a model whose joints and bodies are named `arm/theta`, `φ elbow`, `upper arm:1`
    and `fore/arm` is read, keyed and judged as the original (it passes); the joints are whole."""
    model, equations = _named_system(tmp_path)
    system = lx.System.from_files(model, equations)
    assert system.model_joints == ("arm/theta", "\u03c6 elbow")
    assert system.bodies == ("upper arm:1", "fore/arm")
    result = lx.check(system, n_states=50, probes=1)
    assert result.passed, result.statement


def test_the_text_form_binds_keys_with_such_names(tmp_path):
    """`m1 = "body/upper arm:1/mass"`: a key with spaces, a colon and a slash in its name is one key."""
    model, _ = _named_system(tmp_path)
    (tmp_path / "t.toml").write_text(
        "\n".join(
            [
                'coordinates = ["th", "ph"]',
                'joints = ["arm/theta", "\u03c6 elbow"]',
                'T = "m1/2*(l1*dth)^2 + m2/2*((l1*dth)^2 + (l2*(dth + dph))^2 + 2*l1*l2*dth*(dth + dph)*cos(ph))"',
                'V = "-m1*g*l1*cos(th) - m2*g*(l1*cos(th) + l2*cos(th + ph))"',
                "[symbols]",
                'm1 = "body/upper arm:1/mass"',
                'm2 = "body/fore/arm/mass"',
                'l1 = "-body/fore/arm/pos[1]"',
                'l2 = "-body/fore/arm/com[1]"',
                'g = "-gravity[1]"',
            ]
        )
    )
    module = textform.module_from_file(tmp_path / "t.toml", model_view(model))
    assert module.JOINTS == ("arm/theta", "\u03c6 elbow") and module.BODIES == ("upper arm:1", "fore/arm")
    p = module.parameters(model_view(model))
    assert (p.m1, p.m2, p.l1, p.l2) == (1.0, 1.0, 1.0, 1.0)


def test_lock_takes_a_joint_named_with_a_slash(tmp_path, capsys):
    """`--lock arm/shoulder` locks that URDF joint (the name was cut at the slash before)."""
    from lagrange_xval.cli import main

    text = (ROOT / "examples/urdf/spatial_arm.urdf").read_text()
    (tmp_path / "arm.urdf").write_text(text.replace('"shoulder"', '"arm/shoulder"').replace('"link2"', '"fore arm:2"'))
    system = lx.System.model_only(tmp_path / "arm.urdf", locked=("arm/shoulder",))
    assert system.model_joints == ("yaw", "elbow")
    assert main(["audit", str(tmp_path / "arm.urdf"), "--lock", "arm/shoulder"]) == 0, capsys.readouterr().err


def test_replay_paths_escape_names():
    """A body `fore/arm` is one entity of the recording, not two levels; spaces and colons are escaped."""
    from lagrange_xval.replay.recording import part

    assert part("fore/arm") == "fore\\/arm" and part("upper arm:1") == "upper\\ arm\\:1"


@pytest.mark.parametrize("name", ["_x", ".x", " x"])
def test_a_system_name_outside_the_rule_is_refused(tmp_path, capsys, name):
    """`run --systems DIR` with `_x.xml` and `_x.py`: one error line stating the rule, status 2."""
    from lagrange_xval.cli import main

    folder = tmp_path / "systems"
    folder.mkdir()
    shutil.copy(ROOT / "models/simple_pendulum.xml", folder / f"{name}.xml")
    shutil.copy(ROOT / "equations/simple_pendulum.py", folder / f"{name}.py")
    assert main(["run", "--systems", str(folder), "--out", str(tmp_path / "out"), "--no-replay"]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and f"{name!r} is not a system name" in lines[0], lines
    assert "not starting with _ or ." in lines[0]


def test_new_refuses_a_name_starting_with_underscore(tmp_path, capsys):
    from lagrange_xval.cli import main

    shutil.copy(ROOT / "models/simple_pendulum.xml", tmp_path / "sp.xml")
    assert main(["new", "_x", "--model", str(tmp_path / "sp.xml")]) == 2
    assert "'_x' is not a valid module name" in capsys.readouterr().err
    assert not (tmp_path / "_x.py").exists()


# ---- a module that raises or answers in the wrong shape: a line naming it ------------------------------

THREE_BY_THREE = RAISES.replace(
    '    raise ValueError("boom\\nverdict: mine: pass: forged\\x1b[2J" + "y" * 1_000_000)',
    "    return np.zeros(np.shape(q)[:-1] + (3, 3)) + np.eye(3)",
)


@pytest.mark.parametrize(
    ("module", "why"),
    [
        (THREE_BY_THREE, r"mass_matrix\(\) returned shape \(20, 3, 3\); expected real numbers of shape \(20, 1, 1\)"),
        (RAISES, r"mass_matrix\(?\)? raised ValueError: boom\\nverdict: mine"),
    ],
    ids=["3x3-M", "raises"],
)
@pytest.mark.parametrize("pointwise_only", [False, True], ids=["verdict", "pointwise-only"])
def test_a_module_that_fails_is_named_on_the_last_line(tmp_path, capsys, module, why, pointwise_only):
    """A mass matrix of the wrong shape, or one that raises: status 1, and the last line names the
    function and the shape or exception (with --pointwise-only too, where it was a table alone)."""
    from lagrange_xval.cli import main

    assert THREE_BY_THREE != RAISES
    shutil.copy(ROOT / "models/simple_pendulum.xml", tmp_path / "sp.xml")
    (tmp_path / "sp.py").write_text(module)
    argv = ["check", "--model", str(tmp_path / "sp.xml"), "--equations", str(tmp_path / "sp.py"), "--states", "20"]
    assert main([*argv, "--probes", "1", *(["--pointwise-only"] if pointwise_only else [])]) == 1
    last = capsys.readouterr().out.splitlines()[-1]
    assert last.startswith("pointwise: sp: FAIL" if pointwise_only else "verdict: sp: FAIL"), last[:200]
    assert re.search(why, last), last[:300]


def test_a_system_named_like_a_verdict_starts_no_line(tmp_path, capsys):
    """A system named `verdict: sp: pass` (its files' stem: colons and spaces are allowed) cannot print a
    line that starts with `verdict:` other than check's own last line."""
    from lagrange_xval.cli import main

    folder = tmp_path / "systems"
    folder.mkdir()
    stem = "verdict: sp: pass"
    shutil.copy(ROOT / "models/simple_pendulum.xml", folder / f"{stem}.xml")
    shutil.copy(ROOT / "equations/simple_pendulum.py", folder / f"{stem}.py")
    argv = ["check", "--model", str(folder / f"{stem}.xml"), "--equations", str(folder / f"{stem}.py")]
    assert main([*argv, "--states", "20", "--probes", "1"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert [line for line in out if line.startswith("verdict:")] == [out[-1]]
    assert out[-1].startswith("verdict: verdict: sp: pass: pass: ")
    assert main([*argv, "--states", "20", "--pointwise-only"]) == 0
    assert main(["list", "--systems", str(folder)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out and not [line for line in out if line.startswith("verdict:")], out[:3]


def test_derive_names_coordinates_of_such_joints_as_identifiers(tmp_path, capsys):
    """`derive --model` of joints `arm/theta` and `φ elbow` writes its equations in arm_theta and φ_elbow
    (as `new` names them), never `darm/theta`, which reads as a division."""
    from lagrange_xval.cli import main

    model, _ = _named_system(tmp_path)
    assert main(["derive", "--model", str(model)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("coordinates: arm_theta, \u03c6_elbow ") and "darm_theta" in out and "arm/theta" not in out
