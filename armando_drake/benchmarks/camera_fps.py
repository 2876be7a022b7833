"""How fast the camera renders: frames per second, colour only and colour + depth.

The scene is the built-in Armando description with its camera (if the model
exists; otherwise a bare camera link) plus a few scene objects, rendered by
the renderer a world would choose (``--renderer``: OpenGL on an X display or
a private Xvfb, else VTK through EGL) at 640x480 (or ``--size``). Each frame moves the
simulation time so that Drake renders anew; the figure is frames rendered per
wall-clock second, after a warm-up frame. The last lines compare the
simulation's real-time factor without a camera and with the camera at its own
rate plus the browser view's publisher (PNG encoding happens only when a
browser asks, so none here). The machine's other load shows in the figures:
run it twice.

    python -m armando_drake.benchmarks.camera_fps [--frames N] [--size 640x480] \
        [--renderer auto|gl|vtk]
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import time
import xml.etree.ElementTree as ET

from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from armando_drake import DEFAULT_DESCRIPTION
from armando_drake.description.camera_sensors import parse_camera_sensors
from armando_drake.description.loader import load_robot
from armando_drake.sensors.camera import AddCameraSensors, choose_renderer
from armando_drake.sensors.image_view import AddImageView
from armando_drake.sensors.objects import AddSceneObjects, Box, Cylinder, SceneObject, Sphere

FALLBACK_URDF = """<?xml version="1.0"?>
<robot name="eye">
  <link name="camera_link">
    <visual><geometry><box size="0.02 0.06 0.02"/></geometry></visual>
  </link>
  <gazebo reference="camera_link">
    <sensor type="camera" name="camera"><update_rate>30</update_rate><camera/></sensor>
  </gazebo>
</robot>
"""

OBJECTS = [
    SceneObject(
        name="table", shape=Box(size=[0.8, 0.8, 0.02]), xyz=[0, 0, -0.042], color=[0.6] * 3 + [1]
    ),
    SceneObject(
        name="blue_disc",
        shape=Cylinder(radius=0.03, length=0.01),
        xyz=[0.12, -0.12, -0.026],
        color=[0, 0, 1, 1],
    ),
    SceneObject(
        name="cube",
        shape=Box(size=[0.03, 0.03, 0.03]),
        xyz=[0.2, -0.05, -0.016],
        collision=False,
    ),
    SceneObject(name="ball", shape=Sphere(radius=0.02), xyz=[0.15, 0.05, -0.011], rpy=[0, 0, 0]),
]


def build(
    width: int,
    height: int,
    *,
    depth: bool,
    view: bool = False,
    camera: bool = True,
    renderer: str = "vtk",
):
    """The diagram, its camera and the scene's description, for one measurement."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.001)
    if DEFAULT_DESCRIPTION.is_file():
        robot = load_robot(plant)
        model, sensors, what = robot.model_instance, robot.cameras, "Armando"
    else:
        (model,) = Parser(plant).AddModelsFromString(FALLBACK_URDF, "urdf")
        X_WL = RigidTransform(RollPitchYaw(0, 0.35, 3.14159), [0.4, -0.15, 0.15])
        plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("camera_link"), X_WL)
        sensors = parse_camera_sensors(ET.fromstring(FALLBACK_URDF), "fallback")
        what = "bare camera link (no Armando model)"
    if not sensors:
        raise SystemExit(f"{what}: no camera sensor block in the description")
    AddSceneObjects(plant, OBJECTS)
    plant.Finalize()
    sensors = [dataclasses.replace(sensors[0], width=width, height=height)] if camera else []
    cameras = AddCameraSensors(
        builder, plant, scene_graph, model, sensors, renderer=renderer, enable_depth=depth
    )
    server = AddImageView(builder, cameras) if view else None
    first = next(iter(cameras.values()), None)
    return builder.Build(), first, f"{what} + {len(OBJECTS)} objects", server


def render_fps(
    width: int, height: int, frames: int, *, depth: bool, renderer: str
) -> tuple[float, str]:
    diagram, camera, what, _ = build(width, height, depth=depth, renderer=renderer)
    context = diagram.CreateDefaultContext()
    sensor_context = camera.sensor.GetMyContextFromRoot(context)
    ports = [camera.sensor.GetOutputPort("color_image")]
    if depth:
        ports.append(camera.sensor.GetOutputPort("depth_image_32f"))
    for port in ports:  # warm up (first frame builds the render pipeline)
        port.Eval(sensor_context)
    start = time.perf_counter()
    for i in range(frames):
        context.SetTime((i + 1) * 1e-3)  # new time: the images are rendered again
        for port in ports:
            port.Eval(sensor_context)
    return frames / (time.perf_counter() - start), what


def real_time_factor(
    width: int, height: int, seconds: float, *, camera: bool, renderer: str
) -> float:
    """Simulated over wall-clock seconds, with the camera and the view attached or not."""
    diagram, _, _, server = build(
        width, height, depth=True, view=camera, camera=camera, renderer=renderer
    )
    try:
        simulator = Simulator(diagram)
        simulator.Initialize()
        start = time.perf_counter()
        simulator.AdvanceTo(seconds)
        return seconds / (time.perf_counter() - start)
    finally:
        if server is not None:
            server.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60, help="frames per measurement")
    parser.add_argument("--size", default="640x480", help="image size WIDTHxHEIGHT")
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated seconds")
    parser.add_argument(
        "--renderer", choices=("auto", "gl", "vtk"), default="auto", help="as camera.renderer"
    )
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))
    logging.basicConfig(level=logging.ERROR)
    renderer = choose_renderer(args.renderer)
    color, what = render_fps(width, height, args.frames, depth=False, renderer=renderer)
    both, _ = render_fps(width, height, args.frames, depth=True, renderer=renderer)
    engine = {"gl": "RenderEngineGl (OpenGL, X display)", "vtk": "RenderEngineVtk (EGL)"}
    print(f"scene: {what}, {width}x{height}, {engine[renderer]}")
    print(f"colour:         {color:7.1f} frames/s ({1000 / color:.1f} ms a frame)")
    print(f"colour + depth: {both:7.1f} frames/s ({1000 / both:.1f} ms a frame)")
    bare = real_time_factor(width, height, args.seconds, camera=False, renderer=renderer)
    viewed = real_time_factor(width, height, args.seconds, camera=True, renderer=renderer)
    print(f"simulation ({args.seconds:g} s), no camera: {bare:6.2f} x real time")
    print(f"simulation, colour + depth at the camera rate + browser view: {viewed:.2f} x real time")


if __name__ == "__main__":
    main()
