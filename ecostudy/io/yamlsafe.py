"""YAML and JSON read without surprises: duplicate keys, YAML 1.1's implicit octal, sexagesimal
and yes/no/on/off booleans, and over-deep nesting are refused by name instead of read quietly.

``0100`` is 64 in YAML 1.1 (PyYAML) and 100 to a reader; ``on: 3`` has the key True; a key given
twice keeps the last value. Each of these once turned a mistyped file into a wrong number.
"""
import re
from functools import partial
from typing import Any, Iterable

import yaml

MAX_DEPTH = 64              # nesting levels of a document
MAX_FILE_BYTES = 50_000_000
MAX_NODES = 5_000_000       # values of a YAML document once its aliases are expanded


class DocumentError(ValueError):
    """A document ecostudy refuses to read; ``field`` names where."""

    def __init__(self, message: str, field: str = "") -> None:
        super().__init__(message)
        self.field = field


_SURPRISING = [
    (re.compile(r"^[-+]?0[0-7_]+$"), "a number with a leading zero (YAML 1.1 reads it as octal)"),
    (re.compile(r"^[-+]?0o[0-7_]+$"), "an octal number"),
    (re.compile(r"^[-+]?[0-9][0-9_]*(:[0-5]?[0-9])+(\.[0-9_]*)?$"), "a sexagesimal number (YAML 1.1 reads 1:30 as 90)"),
    (re.compile(r"^(?:yes|Yes|YES|no|No|NO|on|On|ON|off|Off|OFF)$"), "a YAML 1.1 boolean word"),
]


class _Loader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate keys and YAML 1.1 implicit types that surprise."""


def _construct_mapping(loader: _Loader, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
    loader.flatten_mapping(node)
    seen: set[Any] = set()
    out: dict[Any, Any] = {}
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        if key in seen:
            raise DocumentError(f"duplicate key at line {key_node.start_mark.line + 1} (the earlier value would "
                                "be dropped)", str(key))
        seen.add(key)
        out[key] = loader.construct_object(value_node, deep=deep)
    return out


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
def _checked(loader: _Loader, node: yaml.ScalarNode, tag: str) -> Any:
    if node.style is None:
        for pattern, what in _SURPRISING:
            if pattern.match(node.value):
                raise DocumentError(f"'{node.value}' at line {node.start_mark.line + 1} is {what}: write it "
                                    "unambiguously (quote text, drop leading zeros, true/false for booleans)")
    return yaml.SafeLoader.yaml_constructors[tag](loader, node)


for _tag in ("tag:yaml.org,2002:int", "tag:yaml.org,2002:bool"):
    _Loader.add_constructor(_tag, partial(_checked, tag=_tag))


def load_yaml(text: str) -> Any:
    """Parse YAML text with :class:`_Loader`: the node graph is checked (:func:`check_nodes`)
    before any Python object is built from it."""
    loader = _Loader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        check_nodes(node)
        return loader.construct_document(node)
    finally:
        loader.dispose()


def check_nodes(root: yaml.Node, budget: int = MAX_NODES, max_depth: int = MAX_DEPTH) -> None:
    """Refuse a YAML node graph whose aliases expand beyond ``budget`` values, that nests deeper
    than ``max_depth`` or that refers to itself, without expanding anything.

    An alias is a reference: ``&a [x, x]`` used nine times by ``&b [*a, ...]``, and so on nine
    levels deep (the "billion laughs"), is a file of 600 bytes holding 9^9 values. Each node is
    visited once; its expanded size and depth are memoised by identity, so the cost is the number
    of distinct nodes, not the expanded size."""
    sizes: dict[int, int] = {}
    depths: dict[int, int] = {}
    open_: set[int] = set()

    def visit(node: yaml.Node, level: int) -> int:
        key = id(node)
        if key in sizes:
            if level + depths[key] > max_depth:
                raise DocumentError(f"nested more than {max_depth} levels deep")
            return sizes[key]
        if key in open_:
            raise DocumentError(f"an alias at line {node.start_mark.line + 1} refers to the value that contains "
                                "it (a recursive document)")
        if level > max_depth:
            raise DocumentError(f"nested more than {max_depth} levels deep")
        children: list[yaml.Node] = []
        if isinstance(node, yaml.MappingNode):
            children = [part for pair in node.value for part in pair]
        elif isinstance(node, yaml.SequenceNode):
            children = node.value
        open_.add(key)
        size, depth = 1, 0
        for child in children:
            size += visit(child, level + 1)
            depth = max(depth, depths[id(child)] + 1)
            if size > budget:
                raise DocumentError(f"its aliases expand to more than {budget:,} values (an alias bomb?); "
                                    "write the data out or use fewer nested aliases")
        open_.discard(key)
        sizes[key], depths[key] = size, depth
        return size

    visit(root, 0)


def unique_keys(pairs: Iterable[tuple[str, Any]]) -> dict[str, Any]:
    """``object_pairs_hook`` for :func:`json.loads` refusing a key given twice."""
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise DocumentError("duplicate key (the earlier value would be dropped)", key)
        out[key] = value
    return out


def check_depth(data: object, depth: int = 0) -> None:
    """Refuse documents nested more than :data:`MAX_DEPTH` levels deep."""
    if depth > MAX_DEPTH:
        raise DocumentError(f"nested more than {MAX_DEPTH} levels deep")
    if isinstance(data, dict):
        for value in data.values():
            check_depth(value, depth + 1)
    elif isinstance(data, list):
        for value in data:
            check_depth(value, depth + 1)
