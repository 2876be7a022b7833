"""Nav2's plugins by name: planners, controllers, costmap layers, behaviours, smoothers.

Nav2's servers load their plugins by the names their YAML gives (``plugin:
"nav2_navfn_planner/NavfnPlanner"``; pluginlib). Here each implemented plugin is a class
that registers itself under its Nav2 name in the registry of its kind, in its own module
with its parameters declared beside it::

    @PLANNERS.register("nav2_navfn_planner::NavfnPlanner", instead="NavFn plans instead")
    class NavfnPlanner:
        Parameters = PlannerParameters  # a dataclass of param() fields

A plugin Nav2 ships that is not implemented here is a substitution, registered once
(:meth:`Registry.substitute`): the implemented plugin that runs instead and, when their
parameters are named otherwise, which of theirs gives which of its own
(``desired_linear_vel`` from DWB's ``max_vel_x``). A substitution is warned about once,
naming both, where the file names it. ``/`` and ``::`` are the same separator (pluginlib
takes both). The generated parameter reference (:mod:`.reference`) lists the registries.
"""

from __future__ import annotations

import dataclasses as dc
import logging
from collections.abc import Callable, Mapping
from typing import Any

from armando_drake.tools.errors import ConfigError

_log = logging.getLogger("armando_drake.navigation")


def normal(name: str) -> str:
    """A plugin name with ``::`` separators (pluginlib takes ``/`` too)."""
    return str(name).replace("/", "::")


@dc.dataclass(frozen=True)
class Plugin:
    """A registered plugin: its Nav2 name, the class that implements it, and, for a
    substitution, the plugin that runs instead and its parameters' names in this one
    (``{implemented plugin's key: this plugin's key}``; None: the same names)."""

    name: str
    cls: Any
    runs_as: str = ""
    renamed: Mapping[str, str] | None = None

    def node(self, node: Mapping) -> dict:
        """The parameters the implementation reads, from this plugin's ``node``."""
        if self.renamed is None:
            return dict(node)
        return {
            "plugin": self.runs_as,
            **{k: node[v] for k, v in self.renamed.items() if v in node},
        }


class Registry:
    """The plugins of one kind (``"planner"``, ``"controller"``, ...), by Nav2 name."""

    def __init__(self, kind: str):
        self.kind = kind
        self._plugins: dict[str, Plugin] = {}
        self._instead: dict[str, str] = {}

    def register(self, name: str, *, instead: str = "") -> Callable[[type], type]:
        """Class decorator: the class implements the plugin ``name``; ``instead`` is what
        a substitution's warning says of it ("NavFn plans instead")."""

        def decorate(cls: type) -> type:
            key = normal(name)
            if key in self._plugins and self._plugins[key].cls is not cls:
                raise ValueError(f"{self.kind} plugin {name!r} is already registered")
            self._plugins[key] = Plugin(key, cls)
            self._instead[key] = instead or f"{cls.__name__} runs instead"
            return cls

        return decorate

    def substitute(self, name: str, runs_as: str, renamed: Mapping[str, str] | None = None):
        """``name`` (not implemented) runs as the registered ``runs_as``."""
        target = self._plugins[normal(runs_as)]
        self._plugins[normal(name)] = Plugin(normal(name), target.cls, target.name, renamed)

    def unregister(self, name: str) -> None:
        """Removes a plugin (for tests that register a toy one)."""
        self._plugins.pop(normal(name), None)

    def implemented(self) -> list[Plugin]:
        """The plugins implemented here, in registration order."""
        return [p for p in self._plugins.values() if not p.runs_as]

    def substituted(self) -> list[Plugin]:
        """The plugins that run as another one."""
        return [p for p in self._plugins.values() if p.runs_as]

    def lookup(self, raw: Any, where: str) -> Plugin:
        """The plugin named ``raw`` at ``where`` (the plugin's node; ``.plugin`` is its
        key); a substitution is warned about; an unknown name is a ConfigError."""
        plugin = self._plugins.get(normal(raw))
        if plugin is None:
            known = ", ".join(p.name for p in self.implemented())
            others = ", ".join(p.name for p in self.substituted())
            raise ConfigError(
                f"{where}.plugin: unknown {self.kind} {raw!r} (known: {known}"
                + (f"; {others} run as implemented ones)" if others else ")")
            )
        return plugin

    def warn_substitution(self, plugin: Plugin, node: Mapping, where: str) -> None:
        """One warning naming a substituted plugin, what runs instead and the parameters
        it takes from it."""
        if not plugin.runs_as:
            return
        instead = self._instead[plugin.runs_as]
        text = f"{where}.plugin: {plugin.name} is not implemented here; {instead}"
        if plugin.renamed is not None:
            taken = [(k, node[v], v) for k, v in plugin.renamed.items() if v in node]
            text += (
                " (" + (", ".join(f"{k}={x} from {v}" for k, x, v in taken) or "its defaults") + ")"
            )
        _log.warning("%s", text)

    def load(self, node: Mapping, where: str, default: str = "") -> tuple[Plugin, dict]:
        """(the plugin, the parameters its implementation reads) of a plugin's ``node``
        (``plugin:`` its name); a substitution warned about once."""
        if not isinstance(node, Mapping) or ("plugin" not in node and not default):
            raise ConfigError(f"{where}.plugin: no plugin type")
        plugin = self.lookup(node.get("plugin", default), where)
        self.warn_substitution(plugin, node, where)
        return plugin, plugin.node(node)


PLANNERS = Registry("planner")
CONTROLLERS = Registry("controller")
LAYERS = Registry("costmap layer")
BEHAVIORS = Registry("behaviour")
SMOOTHERS = Registry("smoother")  # the smoother server's slot (navigation/smoother.py)
