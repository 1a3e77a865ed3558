"""A person's Matlab function run by GNU Octave, inside the worker process of its module.

The worker of a `.m` file (handwritten/matlab.py writes its small Python module) starts one `octave-cli`
for its whole life and asks it for the derivatives of many states at once: the states go to Octave in
a `.mat` file scipy writes, Octave loops over them calling the person's function as written (`dydt =
f(t, y)`, `f(t, y, p)`, `f(t, y, tau)` or `f(t, y, p, tau)`), saves the answers in a `.mat` file scipy
reads, and prints one line that says so. A request is one line written to a named pipe opened for it
alone (Octave reads a pipe it keeps open only in blocks; a pipe closed after each line ends each read).

Octave is the worker's child in the worker's process group, PID namespace and memory limit, and dies
with it (PR_SET_PDEATHSIG): it is judged under the module's time limit, and nothing it starts outlives
the command. (oct2py, the bridge people use from Python, runs Octave in a pseudo-terminal session of its
own, outside the worker's process group, and brings a Jupyter kernel's dependencies; what is needed here
is a loop and two files.)

    octave = Octave("/home/me/pendulum", "double_bob_pendulum", mode="t,y")
    dydt = octave.derivatives(Y, P, TAU)   # Y: (N, 2n) states [q, v]; dydt: (N, 2n)
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..core.parallel import parent_death_signal

EXECUTABLE = "octave-cli"
INSTALL_HINT = "GNU Octave runs a .m file here; install it with `apt-get install octave` (Debian, as root)"
NUMBERS_ONLY = (
    "a Matlab function runs in Octave on numbers, and the reference, chaos and experiments integrate the "
    "equations as expressions (a Taylor method)"
)
ANSWER = "lagrange-xval-answer"  # the first word of Octave's line that ends a request (the rest is printed by f)
# How each form of the function is called, by the names of its inputs after (t, y): the Octave call.
CALLS = {
    "t,y": "f(0, Y(:, k))",
    "t,y,p": "f(0, Y(:, k), P)",
    "t,y,tau": "f(0, Y(:, k), TAU(:, k))",
    "t,y,p,tau": "f(0, Y(:, k), P, TAU(:, k))",
}
SERVE = """function lagrange_xval_serve(request)
  % Answers each request line (a .mat file of states) until 'quit': written by lagrange-xval.
  crash_dumps_octave_core(false); sighup_dumps_octave_core(false); sigterm_dumps_octave_core(false);
  more off;
  while true
    fid = fopen(request, 'r'); line = fgetl(fid); fclose(fid);
    if ~ischar(line) || strcmp(line, 'quit'), break; end
    try
      S = load(line);
      out = lagrange_xval_states(S.name, S.Y, S.P, S.TAU);
      save('-v6', [line '.out'], 'out');
      printf('\\n%s ok\\n', '{answer}');
    catch err
      printf('\\n%s error %s\\n', '{answer}', strrep(strrep(err.message, char(10), ' '), char(13), ' '));
    end
    fflush(stdout);
  end
end
"""
STATES = """function out = lagrange_xval_states(name, Y, P, TAU)
  % The function's dydt at every column of Y: written by lagrange-xval.
  f = str2func(name);
  out = zeros(size(Y));
  for k = 1:size(Y, 2)
    d = {call};
    if numel(d) ~= size(Y, 1)
      error('%s returned %d values for a state of %d; dydt = [dq; dv] has one per entry of y', ...
            name, numel(d), size(Y, 1));
    end
    out(:, k) = double(d(:));
  end
end
"""


class OctaveError(RuntimeError):
    """What Octave said when the person's function failed (its own message, on one line)."""


class Octave:
    """One octave-cli serving one Matlab function's derivatives (see the module's docstring).

    Args:
        folder: the .m file's folder (on Octave's path, so the function and what it calls are found).
        name: the function's name (the file's stem, as Matlab calls it).
        mode: how it is called: one of CALLS.
    """

    def __init__(self, folder: str, name: str, mode: str) -> None:
        if shutil.which(EXECUTABLE) is None:
            raise OctaveError(f"{EXECUTABLE} is not on this machine: {INSTALL_HINT}")
        self.name = name
        self.dir = Path(tempfile.mkdtemp(prefix="lagrange-xval-octave-"))
        (self.dir / "lagrange_xval_serve.m").write_text(SERVE.format(answer=ANSWER))
        (self.dir / "lagrange_xval_states.m").write_text(STATES.format(call=CALLS[mode]))
        self.request = self.dir / "request"
        os.mkfifo(self.request)
        self.errors = open(self.dir / "stderr", "wb")  # noqa: SIM115 - Octave's warnings, read when it fails
        self.proc = subprocess.Popen(
            [EXECUTABLE, "--no-gui", "--norc", "--quiet", "--no-window-system", "--no-history"]
            + ["--path", str(self.dir), "--path", folder, "--eval", f"lagrange_xval_serve('{self.request}')"],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=self.errors,
            cwd=self.dir,
            preexec_fn=parent_death_signal(),  # noqa: PLW1509 - Octave dies with the thread that started it
        )

    def accelerations(self, p: object, q: object, v: object, tau: object, fields: list[str]) -> np.ndarray:
        """The contract's qacc(p, q, v, tau) of the function: a = dydt[n:] at every state (..., n), in one
        request; the function's dq must be y's v (a state-space form's first half)."""
        arrays = [np.asarray(x) for x in (q, v, tau)]
        if any(a.dtype == object for a in arrays) or any(not _number(getattr(p, f)) for f in fields):
            raise TypeError(NUMBERS_ONLY)
        q_, v_, tau_ = (a.astype(float) for a in arrays)
        n = q_.shape[-1]
        lead = np.broadcast_shapes(q_.shape[:-1], v_.shape[:-1], tau_.shape[:-1])
        Y = np.concatenate([np.broadcast_to(q_, (*lead, n)), np.broadcast_to(v_, (*lead, n))], axis=-1)
        TAU = np.broadcast_to(tau_, (*lead, tau_.shape[-1]))
        N = int(np.prod(lead, dtype=int))
        P = {f: float(getattr(p, f)) for f in fields}
        out = self.derivatives(Y.reshape(N, 2 * n), P, TAU.reshape(N, TAU.shape[-1]))
        dq = out[:, :n].reshape(*lead, n)
        if not np.allclose(dq, np.broadcast_to(v_, (*lead, n)), rtol=1e-12, atol=1e-12, equal_nan=True):
            k = int(np.argmax(np.abs(dq - np.broadcast_to(v_, (*lead, n))).reshape(-1, n).max(axis=1)))
            raise OctaveError(
                f"{self.name}'s dydt(1:{n}) is not y({n + 1}:{2 * n}), the velocities (state {k}: "
                f"{np.round(dq.reshape(-1, n)[k], 6).tolist()} for "
                f"{np.round(Y.reshape(-1, 2 * n)[k, n:], 6).tolist()}); "
                "y = [q; dq/dt] and dydt = [dq/dt; d2q/dt2]"
            )
        return out[:, n:].reshape(*lead, n)

    def derivatives(self, Y: np.ndarray, P: Mapping[str, float], TAU: np.ndarray) -> np.ndarray:
        """dydt of every row of Y (N, 2n), with struct P and inputs TAU (N, n): (N, 2n) floats."""
        import scipy.io

        path = self.dir / "states.mat"
        struct = {k: float(v) for k, v in P.items()} or {"none": 0.0}
        scipy.io.savemat(path, {"name": self.name, "Y": Y.T, "P": struct, "TAU": TAU.T}, format="5")
        with open(self.request, "w") as pipe:  # blocks until Octave opens it: Octave alive and waiting
            pipe.write(f"{path}\n")
        said = self._answer()
        if said != "ok":
            raise OctaveError(said.removeprefix("error ").strip() or "Octave failed")
        out = np.asarray(scipy.io.loadmat(f"{path}.out")["out"], dtype=float)
        if out.shape != Y.T.shape:
            raise OctaveError(f"{self.name} gave {out.shape} for states {Y.T.shape}")
        return np.ascontiguousarray(out.T)

    def _answer(self) -> str:
        """The rest of Octave's answer line (what the person's function printed is skipped)."""
        assert self.proc.stdout is not None
        for raw in self.proc.stdout:
            line = raw.decode(errors="replace").strip()
            if line.startswith(ANSWER + " "):
                return line[len(ANSWER) + 1 :]
        self.proc.wait()
        raise OctaveError(f"Octave ended (status {self.proc.returncode}){self._stderr_tail()}")

    def _stderr_tail(self) -> str:
        self.errors.flush()
        text = (self.dir / "stderr").read_text(errors="replace").strip().splitlines()
        return f": {' '.join(text[-3:])}" if text else ""

    def close(self) -> None:
        """Octave asked to quit (then killed), its folder removed."""
        if self.proc.poll() is None:
            try:
                fd = os.open(self.request, os.O_WRONLY | os.O_NONBLOCK)  # fails at once if Octave is not reading
                os.write(fd, b"quit\n")
                os.close(fd)
                self.proc.wait(timeout=5)
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait()
        self.errors.close()
        shutil.rmtree(self.dir, ignore_errors=True)


def _number(x: object) -> bool:
    return isinstance(x, (int, float, np.floating, np.integer)) and not isinstance(x, bool)
