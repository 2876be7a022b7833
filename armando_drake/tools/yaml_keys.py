"""A YAML mapping that gives a key twice is a mistake: the loaders (Drake's and
PyYAML's) keep the last value without a word, so the first one silently does
nothing. :func:`duplicate_key` finds the first such key, with its line."""

from __future__ import annotations

import yaml


def duplicate_key(text: str) -> tuple[int, str] | None:
    """(line, ``"key 'k' is given twice (first at line M) ..."``) for the first mapping of
    the YAML ``text`` that gives a key twice, else None (also for text that is not YAML:
    the loader reports that itself). Tags (``!Sinusoid``) are not interpreted."""
    try:
        nodes = list(yaml.compose_all(text, Loader=yaml.SafeLoader))
    except yaml.YAMLError:
        return None
    stack = [node for node in nodes if node is not None]
    seen_nodes: set[int] = set()  # an alias is the node it names: each is checked once
    while stack:
        node = stack.pop()
        if id(node) in seen_nodes:
            continue
        seen_nodes.add(id(node))
        if isinstance(node, yaml.MappingNode):
            seen: dict[str, int] = {}
            for key, value in node.value:
                stack.append(value)
                if not isinstance(key, yaml.ScalarNode) or key.value == "<<":
                    continue
                line = key.start_mark.line + 1
                if key.value in seen:
                    return line, (
                        f"key {key.value!r} is given twice (first at line "
                        f"{seen[key.value]}); only the last would count"
                    )
                seen[key.value] = line
        elif isinstance(node, yaml.SequenceNode):
            stack.extend(node.value)
    return None
