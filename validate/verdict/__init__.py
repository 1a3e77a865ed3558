"""The verdict on one system, decided in one place (`decide.decide`), and what it calls.

decide       model checks -> pointwise -> every term at the model's and the probes' parameters
verdict      the derivation term by term; inputs: derivations taking the actuators' controls
pointwise    the sources compared at seeded random states
terms        what the engines say each term is; probes: the parameter sets each number moves in
modelsync    do the sources describe the same model (before any dynamics)
judge        every printed form of the notes, term by term
explain, explain_inputs, words   what a wrong expression lacks, in the person's words
asif         the physical parameter a wrong derivation behaves as (another chain's equations)
"""

__all__ = [
    "asif",
    "decide",
    "explain",
    "explain_inputs",
    "inputs",
    "judge",
    "modelsync",
    "pointwise",
    "probes",
    "terms",
    "verdict",
    "words",
]
