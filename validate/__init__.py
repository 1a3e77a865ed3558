"""The harness (installed as `lagrange_xval.validate`), in subpackages that follow the data one way:

    systems -> engines -> dynamics -> checks -> pipeline, studies -> cli
                      results (schema, provenance, I/O) -> report, replay

A module imports its own package and the layers below it; report and replay read results (replay
also the model, to place the bodies it draws); errors, inputs, parallel and checks.tolerances serve
every layer. tests/test_architecture.py holds this shape.
"""
