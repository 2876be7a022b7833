"""The optional features and the extras that install them (``pyproject.toml``'s
``[project.optional-dependencies]``).

A feature whose modules are not installed is refused before the run with one line naming
the extra, ``pip install 'armando-drake[vision]'``, which the command lines print as
``error: ...`` and exit 2 (:class:`MissingExtraError` is an input error): never as an
internal error with a ``ModuleNotFoundError`` half way through building the world.
"""

import importlib.util

from armando_drake.tools.errors import UserInputError

# The optional feature -> (its extra, the modules it imports, what they are called).
EXTRAS = {
    "vision": ("vision", ("cv2",), "OpenCV (cv2)"),  # detectors and ArUco marker images
    "perception": ("perception", ("sklearn", "scipy"), "scikit-learn and SciPy"),  # point clouds
    "navigation": ("navigation", ("scipy",), "SciPy"),  # costmaps, the planner, the world's map
    "ros2": ("ros2", ("cyclonedds",), "Cyclone DDS (cyclonedds)"),  # --ros2
    "foxglove": ("ros2", ("foxglove",), "the Foxglove SDK (foxglove)"),  # --foxglove
    "cluster": ("cluster", ("ray",), "Ray (ray)"),  # sweeps on Ray
    # python -m armando_drake.learn: training and export of the learned IK network
    "learn": (
        "learn",
        ("sklearn", "skl2onnx", "onnxruntime"),
        "scikit-learn, skl2onnx and ONNX Runtime",
    ),
    "learned_ik": ("learn", ("onnxruntime",), "ONNX Runtime (onnxruntime)"),  # running it
}


class MissingExtraError(UserInputError):
    """An optional feature asked for whose modules are not installed."""


def missing_modules(names) -> list[str]:
    """The modules of ``names`` that cannot be imported here."""
    missing = []
    for name in names:
        try:
            found = importlib.util.find_spec(name) is not None
        except (ImportError, ValueError):  # a parent that fails, a module without a spec
            found = False
        if not found:
            missing.append(name)
    return missing


def extra_hint(feature: str) -> str:
    """``pip install 'armando-drake[extra]'`` for ``feature`` (a key of :data:`EXTRAS`)."""
    return f"pip install 'armando-drake[{EXTRAS[feature][0]}]'"


def missing_extra(feature: str) -> str | None:
    """``"needs OpenCV (cv2), which is not installed: pip install ..."`` when a module of
    ``feature`` (a key of :data:`EXTRAS`) is missing; None when all are installed."""
    _, modules, label = EXTRAS[feature]
    if not missing_modules(modules):
        return None
    return f"needs {label}, which is not installed: {extra_hint(feature)}"


def require_extra(feature: str, what: str) -> None:
    """Raises :class:`MissingExtraError` ``"<what> needs ..."`` (:func:`missing_extra`)
    when a module of ``feature`` is missing; ``what`` is the key or option asking for it."""
    problem = missing_extra(feature)
    if problem:
        raise MissingExtraError(f"{what} {problem}")
