"""The one serialisation helper of frozen records (graybox.record_json) and its FrozenMap."""
from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Mapping

import pytest

from graybox import record_json
from graybox.exceptions import ArtifactError
from graybox.frozen_map import FrozenMap
from graybox.models import ModelSpec, load_model


@dataclass(frozen=True)
class Leaf:
    name: str
    weight: float = 1.0


@dataclass(frozen=True)
class Tree:
    leaves: tuple[Leaf, ...]
    grid: tuple[tuple[float, ...], ...]
    pair: tuple[int, str]
    labels: FrozenMap[str, int]
    extra: dict
    best: Leaf | None = None
    span: float | str = "auto"
    flag: bool = False

    @classmethod
    def migrate(cls, data: Mapping) -> dict:
        data = dict(data)
        if "old_span" in data:
            data["span"] = data.pop("old_span")
        return data


@dataclass(frozen=True)
class Forest:
    trees: tuple[Tree, ...]


def make_tree(**changes) -> Tree:
    fields = dict(leaves=(Leaf("a"), Leaf("b", 1 / 3)), grid=((0.1, -2 ** -40), (1e-300,)),
                  pair=(2, "x"), labels=FrozenMap(b=2, a=1), extra={"any": [1, None]},
                  best=Leaf("c", 0.5), span=30.0, flag=True)
    fields.update(changes)
    return Tree(**fields)


def round_trip(record):
    return record_json.from_dict(type(record), json.loads(json.dumps(record_json.to_dict(record))))


def test_round_trip_is_exact_for_nested_records_tuples_maps_and_unions():
    tree = make_tree()
    forest = Forest((tree, make_tree(best=None, span="auto", labels=FrozenMap())))
    assert round_trip(forest) == forest
    assert json.dumps(record_json.to_dict(round_trip(forest))) == json.dumps(record_json.to_dict(forest))
    assert list(record_json.to_dict(tree)["labels"]) == ["b", "a"]      # order is kept
    assert isinstance(round_trip(tree).labels, FrozenMap)
    assert isinstance(round_trip(tree).grid[0], tuple)


def test_defaults_fill_absent_fields_and_integers_become_floats():
    data = record_json.to_dict(make_tree())
    del data["best"], data["span"], data["flag"]
    data["leaves"][0]["weight"] = 2
    tree = record_json.from_dict(Tree, data)
    assert tree.best is None and tree.span == "auto" and tree.flag is False
    assert tree.leaves[0].weight == 2.0 and isinstance(tree.leaves[0].weight, float)


def test_a_run_of_numbers_reads_as_floats():
    data = record_json.to_dict(make_tree())
    data["grid"] = [[1, 2.5, -3], []]
    grid = record_json.from_dict(Tree, data).grid
    assert grid == ((1.0, 2.5, -3.0), ())
    assert all(type(v) is float for v in grid[0])


def test_migrate_hook_applies_wherever_the_record_is_nested():
    data = record_json.to_dict(Forest((make_tree(),)))
    data["trees"][0]["old_span"] = data["trees"][0].pop("span")
    assert record_json.from_dict(Forest, data) == Forest((make_tree(),))


@pytest.mark.parametrize("mutate, message", [
    (lambda d: d.update(color="red"), r"Tree: unknown field\(s\) \['color'\]"),
    (lambda d: d.pop("grid"), r"Tree: missing field\(s\) \['grid'\]"),
    (lambda d: d["leaves"][1].update(weight="heavy"), "Leaf.weight must be a number"),
    (lambda d: d["leaves"][1].update(weight=True), "Leaf.weight must be a number"),
    (lambda d: d.update(flag=1), "Tree.flag must be true or false"),
    (lambda d: d.update(pair=[2]), "Tree.pair must have 2 items"),
    (lambda d: d.update(pair=[2.5, "x"]), r"Tree.pair\[0\] must be an integer"),
    (lambda d: d.update(grid=[[0.1], 3]), r"Tree.grid\[1\] must be an array"),
    (lambda d: d.update(labels={"a": "one"}), r"Tree.labels\['a'\] must be an integer"),
    (lambda d: d.update(labels=[1]), "Tree.labels must be an object"),
    (lambda d: d.update(span=None), "Tree.span must not be null"),
    (lambda d: d.update(span=[1]), "Tree.span must be a number or a string"),
    (lambda d: d.update(best=[1]), "Leaf: expected an object, got list"),
    (lambda d: d["leaves"].append(None), r"Tree.leaves\[2\] must not be null"),
    (lambda d: d.update(grid=[[0.1, True]]), r"Tree.grid\[0\]\[1\] must be a number"),
    (lambda d: d.update(grid=[[0.1, 2, "3"]]), r"Tree.grid\[0\]\[2\] must be a number"),
    (lambda d: d.update(grid=[[0.1, float("nan")]]),
     r"Tree.grid\[0\]\[1\] must be a finite number, got nan"),
    (lambda d: d.update(grid=[[None]]), r"Tree.grid\[0\]\[0\] must not be null"),
])
def test_malformed_input_names_the_record_and_field(mutate, message):
    data = record_json.to_dict(make_tree())
    mutate(data)
    with pytest.raises(ArtifactError, match=message):
        record_json.from_dict(Tree, data)


def test_a_record_refusing_its_values_is_an_artifact_error():
    @dataclass(frozen=True)
    class Positive:
        value: float

        def __post_init__(self):
            if self.value <= 0:
                raise ValueError("value must be > 0")

    with pytest.raises(ArtifactError, match="Positive: value must be > 0"):
        record_json.from_dict(Positive, {"value": -1})
    with pytest.raises(ArtifactError, match="Positive: expected an object, got str"):
        record_json.from_dict(Positive, "value")


def test_frozen_map_is_an_ordered_hashable_read_only_mapping():
    parameters = FrozenMap({"b": 2.0, "a": 1.0})
    assert parameters == {"a": 1.0, "b": 2.0} and list(parameters) == ["b", "a"]
    assert hash(parameters) == hash(FrozenMap(a=1.0, b=2.0))
    assert parameters != FrozenMap(a=1.0) and parameters != [("b", 2.0), ("a", 1.0)]
    with pytest.raises(TypeError):
        parameters["c"] = 3.0
    source = {"x": 1}
    copy = FrozenMap(source)
    source["x"] = 2
    assert copy["x"] == 1


def test_model_spec_rebuilds_its_white_box():
    model = load_model("graybox.models.gas_turbine:LangevinShaft", {"gamma": 0.06},
                       {"omega": "shaft_speed"})
    spec = ModelSpec.from_model(model)
    assert spec.to_dict() == model.to_dict()
    assert ModelSpec.from_dict(json.loads(json.dumps(spec.to_dict()))) == spec
    again = spec.load()
    assert type(again) is type(model) and again.parameters == model.parameters
    assert again.columns == model.columns
    assert ModelSpec(spec.spec, dict(model.parameters), dict(model.columns)) == spec
    assert hash(ModelSpec(spec.spec, dict(model.parameters), dict(model.columns))) == hash(spec)


def test_json_text_round_trip_and_text_that_is_not_json():
    tree = make_tree()
    text = record_json.to_json(tree, indent=2)
    assert text == json.dumps(record_json.to_dict(tree), indent=2)
    assert record_json.from_dict(Tree, record_json.parse_json(text, "tree")) == tree
    assert record_json.parse_json(text.encode(), "tree") == json.loads(text)
    with pytest.raises(ArtifactError, match=r"^tree is not valid JSON: Expecting property name"):
        record_json.parse_json("{'name': 'a'}", "tree")
    with pytest.raises(ArtifactError, match=r"^tree is not valid JSON: 'utf-8' codec"):
        record_json.parse_json(b"\x80", "tree")


@dataclass(frozen=True)
class Measured:
    transient_fields = frozenset({"samples"})

    value: float
    samples: object = None


def test_transient_fields_are_never_written_and_read_as_their_default():
    import numpy as np

    measured = Measured(2.0, np.arange(3))
    assert record_json.to_dict(measured) == {"value": 2.0}
    assert round_trip(measured) == Measured(2.0)
    with pytest.raises(ArtifactError, match=r"unknown field\(s\) \['samples'\]"):
        record_json.from_dict(Measured, {"value": 2.0, "samples": [0, 1, 2]})
