"""results.json written from systems' texts made in the workers is the same text as written whole."""

from __future__ import annotations

import json

import numpy as np
from lagrange_xval.results import dumps, system_json


def _results() -> dict:
    a = {"name": "a", "q": np.linspace(0, 1, 5), "nested": {"z": [1, 2.5, float("nan")], "b": np.float64(np.inf)}}
    b = {"name": "b", "passed": np.bool_(True), "n": np.int64(3), "empty": {}, "rows": [{"x": 1}]}
    return {"meta": {"seed": 0}, "passed": False, "systems": {"b": b, "a": a}, "tolerances": {"t": 1e-9}}


def test_the_workers_texts_give_the_same_results_json():
    results = _results()
    whole = dumps(results)
    texts = {name: system_json(s) for name, s in results["systems"].items()}
    assert dumps(results, texts) == whole
    assert dumps(results, {"a": texts["a"]}) == whole  # a system without its text is written here
    assert json.loads(whole)["systems"]["a"]["nested"]["b"] == "inf"


def test_no_systems_and_a_stale_text_can_be_told_apart():
    results = _results()
    assert dumps({**results, "systems": {}}, {"a": "{}"}) == dumps({**results, "systems": {}})
    stale = {"a": system_json({**results["systems"]["a"], "name": "changed"})}
    assert dumps(results, stale) != dumps(results)  # the text is used as given: the caller keeps it current
