"""The foundations every room may use, importing nothing of the harness above them.

arrays       the names of the numbers' types: Vector, Matrix, Json
errors       HarnessError and its kinds: one line for a person, what is wrong and what is valid
inputs       strict input: files are what they claim, sizes bounded before reading
files        every file the harness writes, created without following a link
guard        the time limit and the no-exit, no-stdout guard around a call
parallel     where sweeps run: any concurrent.futures executor
tolerances   the named tolerance tiers, each with its reason
cachedir     the Cache value: where what was computed once is kept, bounded
cache        the signed on-disk entries of that cache
memo         what is computed once per System and a few hashable arguments
package      where the package's own files are (the harness, models/, equations/)
"""

__all__ = [
    "arrays",
    "cache",
    "cachedir",
    "errors",
    "files",
    "guard",
    "inputs",
    "memo",
    "package",
    "parallel",
    "tolerances",
]
