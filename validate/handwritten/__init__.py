"""A person's equations module, read into one form: M(q), bias(q, v) and passive(q, v) (form (a)).

forms        the six forms a derivation can take (a-e, and text) brought to form (a): written_form
proxy, worker, child   the module imported and called in a process of its own, under one budget
textform, expression   equations as text (TOML): bounded expressions read into sympy
hamiltonian  form (e), H(q, pm), brought to the energies of form (d)
tracing      the module's numpy code traced with symbolic values (code generation, the reference)
values       what a function returns, made a real float array or refused by name
reads        which model numbers `parameters(model)` reads
textcode     the text form's expressions as a numpy module, run in the worker like a person's module
"""

__all__ = [
    "child",
    "expression",
    "forms",
    "hamiltonian",
    "proxy",
    "reads",
    "textcode",
    "textform",
    "tracing",
    "values",
    "worker",
]
