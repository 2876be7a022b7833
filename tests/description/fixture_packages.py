"""The test fixture packages of tests/description/fixtures, copied into a workspace with
their mesh files written (tiny STL, OBJ + MTL, Collada with a material and a texture)."""

# ruff: noqa: E501  (the Collada template stays one readable XML document)

import shutil
from pathlib import Path

import numpy as np

FIXTURES = Path(__file__).resolve().parent / "fixtures"
# [0..1] RGB of the Collada file's coloured body and of its texture.
DAE_RED = (0.8, 0.1, 0.1)
TEXTURE_BLUE = (0, 0, 255)
# [0..1] diffuse colour of part.mtl.
OBJ_GREEN = (0.1, 0.7, 0.2)


def box(size, offset=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (8, 3) and outward triangles (12, 3) of a box of ``size`` [m] at ``offset``."""
    hx, hy, hz = np.asarray(size, dtype=float) / 2
    vertices = np.array([[x, y, z] for x in (-hx, hx) for y in (-hy, hy) for z in (-hz, hz)])
    faces = np.array(
        [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
         [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    )  # fmt: skip
    return vertices + np.asarray(offset, dtype=float), faces


def write_stl(path: Path, size, offset=(0.0, 0.0, 0.0)) -> None:
    import trimesh

    vertices, faces = box(size, offset)
    trimesh.Trimesh(vertices, faces).export(path)


def _floats(values) -> str:
    return " ".join(f"{v:g}" for v in np.ravel(values))


def _collada_geometry(name: str, size, offset, textured: bool) -> str:
    vertices, faces = box(size, offset)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]] * 2, dtype=float)
    inputs = f'<input semantic="VERTEX" source="#{name}-v" offset="0"/>'
    indices = faces.ravel()
    uv_source = ""
    if textured:
        inputs += f'<input semantic="TEXCOORD" source="#{name}-uv" offset="1" set="0"/>'
        indices = np.column_stack([faces.ravel(), faces.ravel()]).ravel()
        uv_source = (
            f'<source id="{name}-uv"><float_array id="{name}-uv-a" count="{uv.size}">'
            f"{_floats(uv)}</float_array><technique_common>"
            f'<accessor source="#{name}-uv-a" count="{len(uv)}" stride="2">'
            '<param name="S" type="float"/><param name="T" type="float"/></accessor>'
            "</technique_common></source>"
        )
    return (
        f'<geometry id="{name}" name="{name}"><mesh>'
        f'<source id="{name}-p"><float_array id="{name}-p-a" count="{vertices.size}">'
        f"{_floats(vertices)}</float_array><technique_common>"
        f'<accessor source="#{name}-p-a" count="{len(vertices)}" stride="3">'
        '<param name="X" type="float"/><param name="Y" type="float"/>'
        '<param name="Z" type="float"/></accessor></technique_common></source>'
        f"{uv_source}"
        f'<vertices id="{name}-v"><input semantic="POSITION" source="#{name}-p"/></vertices>'
        f'<triangles material="{name}-material" count="{len(faces)}">{inputs}'
        f"<p>{_floats(indices)}</p></triangles></mesh></geometry>"
    )


def write_collada(path: Path, unit: float = 1.0) -> None:
    """Two boxes in one file, in units of ``unit`` metres: a 4 cm body of diffuse colour
    DAE_RED and, beside it (+x), a 2 x 2 x 6 cm plate textured with ``texture.png``."""
    from PIL import Image

    scale = 1.0 / unit
    body = _collada_geometry("body", np.array([0.04] * 3) * scale, (0, 0, 0), False)
    plate = _collada_geometry(
        "plate", np.array([0.02, 0.02, 0.06]) * scale, np.array([0.05, 0, 0]) * scale, True
    )
    r, g, b = DAE_RED
    path.write_text(
        f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="custom" meter="{unit}"/><up_axis>Z_UP</up_axis></asset>
  <library_images><image id="tex-image"><init_from>texture.png</init_from></image></library_images>
  <library_effects>
    <effect id="red-effect"><profile_COMMON><technique sid="common"><phong>
      <diffuse><color>{r} {g} {b} 1</color></diffuse></phong></technique></profile_COMMON></effect>
    <effect id="tex-effect"><profile_COMMON>
      <newparam sid="tex-surface"><surface type="2D"><init_from>tex-image</init_from></surface></newparam>
      <newparam sid="tex-sampler"><sampler2D><source>tex-surface</source></sampler2D></newparam>
      <technique sid="common"><phong><diffuse><texture texture="tex-sampler" texcoord="UVMap"/></diffuse></phong></technique>
    </profile_COMMON></effect>
  </library_effects>
  <library_materials>
    <material id="red" name="red"><instance_effect url="#red-effect"/></material>
    <material id="tex" name="tex"><instance_effect url="#tex-effect"/></material>
  </library_materials>
  <library_geometries>{body}{plate}</library_geometries>
  <library_visual_scenes><visual_scene id="scene">
    <node id="body-node"><instance_geometry url="#body"><bind_material><technique_common>
      <instance_material symbol="body-material" target="#red"/></technique_common></bind_material></instance_geometry></node>
    <node id="plate-node"><instance_geometry url="#plate"><bind_material><technique_common>
      <instance_material symbol="plate-material" target="#tex"><bind_vertex_input semantic="UVMap" input_semantic="TEXCOORD" input_set="0"/></instance_material></technique_common></bind_material></instance_geometry></node>
  </visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
"""
    )
    pixels = np.zeros((4, 4, 3), dtype=np.uint8)
    pixels[:] = TEXTURE_BLUE
    Image.fromarray(pixels).save(path.parent / "texture.png")


def write_obj_with_mtl(path: Path, size, normals: bool = True) -> None:
    """A box as OBJ (with face normals unless ``normals`` is False) using ``part.mtl``'s
    material of colour OBJ_GREEN."""
    vertices, faces = box(size)
    r, g, b = OBJ_GREEN
    path.with_suffix(".mtl").write_text(f"newmtl green\nKd {r} {g} {b}\nd 1\n")
    lines = [f"mtllib {path.with_suffix('.mtl').name}\nusemtl green\n"]
    lines += [f"v {x:g} {y:g} {z:g}\n" for x, y, z in vertices]
    if normals:
        for a, b_, c in faces:
            n = np.cross(vertices[b_] - vertices[a], vertices[c] - vertices[a])
            nx, ny, nz = n / np.linalg.norm(n)
            lines.append(f"vn {nx:g} {ny:g} {nz:g}\n")
        lines += [f"f {a + 1}//{k + 1} {b_ + 1}//{k + 1} {c + 1}//{k + 1}\n"
                  for k, (a, b_, c) in enumerate(faces)]  # fmt: skip
    else:
        lines += [f"f {a + 1} {b_ + 1} {c + 1}\n" for a, b_, c in faces]
    path.write_text("".join(lines))


def write_meshes(package: Path) -> None:
    """The mesh files a fixture package refers to."""
    name = package.name
    if name == "world_arm_description":
        (package / "meshes").mkdir(exist_ok=True)
        write_stl(package / "meshes" / "rod.stl", (0.04, 0.04, 0.1))
    elif name == "mesh_description":
        meshes = package / "meshes"
        meshes.mkdir(exist_ok=True)
        write_collada(meshes / "body.dae", unit=0.01)  # centimetres
        write_obj_with_mtl(meshes / "part.obj", (0.03, 0.03, 0.05))
        write_stl(meshes / "rod_mm.stl", (20, 20, 100), (0, 0, 50))  # millimetres


def make_workspace(root: Path, names=None) -> Path:
    """Copies the fixture packages (all, or ``names``) into ``root``/src; returns src."""
    src = root / "src"
    for package in sorted(FIXTURES.iterdir()):
        if package.is_dir() and (names is None or package.name in names):
            target = src / package.name
            shutil.copytree(package, target)
            write_meshes(target)
    return src


def box_inertia(mass: float, size) -> str:
    """The ``<inertia>`` of a solid box of ``mass`` [kg] and ``size`` [m] about its centre."""
    a, b, c = size
    return (
        f'<inertia ixx="{mass * (b * b + c * c) / 12:.9g}" iyy="{mass * (a * a + c * c) / 12:.9g}" '
        f'izz="{mass * (a * a + b * b) / 12:.9g}" ixy="0" ixz="0" iyz="0"/>'
    )


# The joints of a six-joint arm: yaw, pitch, pitch, roll, pitch, roll.
ARM_AXES = ("0 0 1", "0 1 0", "0 1 0", "0 0 1", "0 1 0", "0 0 1")


def chain_urdf(
    name: str,
    *,
    width: float,
    lengths,
    masses,
    efforts,
    base=(0.2, 0.1, 1.0),
    axes=ARM_AXES,
    inertials: bool = True,
) -> str:
    """A serial arm standing upright at home: a base box (``base``: side [m], height [m],
    mass [kg]) and one box link per joint, ``width`` [m] square and ``lengths[i]`` [m]
    tall, of ``masses[i]`` [kg] (with their ``<inertial>`` unless ``inertials`` is
    False), each joint about ``axes[i]`` at the top of the link below, limits +-2.9 rad
    and ``efforts[i]`` [N m]. No ``<ros2_control>`` or transmission: every joint is a
    position joint."""
    side, height, base_mass = base
    links = [
        f'<link name="base_link"><visual><origin xyz="0 0 {height / 2}"/><geometry>'
        f'<box size="{side} {side} {height}"/></geometry></visual><collision><origin '
        f'xyz="0 0 {height / 2}"/><geometry><box size="{side} {side} {height}"/></geometry>'
        f'</collision><inertial><origin xyz="0 0 {height / 2}"/><mass value="{base_mass}"/>'
        f"{box_inertia(base_mass, (side, side, height))}</inertial></link>"
    ]
    parent, top = "base_link", height
    for i, (length, mass, effort) in enumerate(zip(lengths, masses, efforts, strict=True)):
        size = (width, width, length)
        shape = f'<origin xyz="0 0 {length / 2}"/><geometry><box size="{width} {width} {length}"/></geometry>'
        inertial = (
            f'<inertial><origin xyz="0 0 {length / 2}"/><mass value="{mass}"/>'
            f"{box_inertia(mass, size)}</inertial>"
            if inertials
            else ""
        )
        links.append(
            f'<link name="link_{i + 1}"><visual>{shape}</visual><collision>{shape}</collision>'
            f"{inertial}</link>"
            f'<joint name="joint_{i + 1}" type="revolute"><parent link="{parent}"/>'
            f'<child link="link_{i + 1}"/><origin xyz="0 0 {top}"/><axis xyz="{axes[i]}"/>'
            f'<limit lower="-2.9" upper="2.9" effort="{effort}" velocity="3"/></joint>'
        )
        parent, top = f"link_{i + 1}", length
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n' + "\n".join(links) + "\n</robot>\n"


def l_profile(thickness: float, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """An L of two bars in the link's x-z plane, ``thickness`` [m] square, from the
    origin along +x and along +z to ``reach`` [m]: vertices and outward triangles."""
    import trimesh

    along_x = trimesh.creation.box(
        extents=(reach, thickness, thickness),
        transform=trimesh.transformations.translation_matrix((reach / 2, 0, thickness / 2)),
    )
    along_z = trimesh.creation.box(
        extents=(thickness, thickness, reach),
        transform=trimesh.transformations.translation_matrix((thickness / 2, 0, reach / 2)),
    )
    both = trimesh.util.concatenate([along_x, along_z])
    return np.asarray(both.vertices), np.asarray(both.faces)


# --------------------------------------------------------------------------------------
# Light arms in the layouts public ROS packages use (controller files of every pattern)

ARM_JOINTS = ("j1", "j2", "j3")

_ARM_LINK = """  <link name="{name}">
    <visual><geometry><box size="0.03 0.03 {length}"/></geometry></visual>
    <collision><geometry><box size="0.03 0.03 {length}"/></geometry></collision>
    <inertial><origin xyz="0 0 {half}"/><mass value="0.1"/>
      <inertia ixx="1e-4" iyy="1e-4" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
"""
_ARM_JOINT = """  <joint name="{prefix}{name}" type="revolute">
    <parent link="{parent}"/><child link="{child}"/>
    <origin xyz="0 0 {z}"/><axis xyz="{axis}"/>
    <limit lower="-2" upper="2" effort="10" velocity="3"/>
  </joint>
"""


def arm_xacro(name: str, *, include: str = "", prefix: str = "", extra: str = "") -> str:
    """A light three-joint arm (links of 0.1 kg) as xacro: ``include`` is a file the
    robot includes (its ros2_control block); ``prefix`` goes before each joint name."""
    links = [("base_link", 0.05)] + [(f"link{k}", 0.15) for k in (1, 2, 3)]
    body = "".join(
        _ARM_LINK.format(name=link, length=length, half=length / 2) for link, length in links
    )
    axes = ("0 0 1", "0 1 0", "0 1 0")
    for k, joint in enumerate(ARM_JOINTS):
        z = 0.05 if k == 0 else 0.15
        body += _ARM_JOINT.format(
            prefix=prefix, name=joint, parent=links[k][0], child=links[k + 1][0], z=z, axis=axes[k]
        )
    included = f'  <xacro:include filename="{include}"/>\n' if include else ""
    return (
        f'<?xml version="1.0"?>\n<robot name="{name}" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        f"{body}{included}{extra}</robot>\n"
    )


def ros2_control_xacro(joints=ARM_JOINTS, *, prefix: str = "", gpio: str = "") -> str:
    """A ros2_control block (as a xacro file to include): position command, position and
    velocity state interfaces on each joint."""
    blocks = "".join(
        f'    <joint name="{prefix}{joint}"><command_interface name="position"/>'
        '<state_interface name="position"/><state_interface name="velocity"/></joint>\n'
        for joint in joints
    )
    return (
        '<?xml version="1.0"?>\n<robot xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        '  <ros2_control name="FixtureArm" type="system">\n'
        "    <hardware><plugin>mock_components/GenericSystem</plugin></hardware>\n"
        f"{blocks}{gpio}  </ros2_control>\n</robot>\n"
    )


ROS1_TRANSMISSIONS = "".join(
    f'  <transmission name="t_{joint}"><type>transmission_interface/SimpleTransmission</type>'
    f'<joint name="{joint}"><hardwareInterface>hardware_interface/PositionJointInterface'
    f'</hardwareInterface></joint><actuator name="m_{joint}"><mechanicalReduction>1'
    "</mechanicalReduction></actuator></transmission>\n"
    for joint in ARM_JOINTS
)


def write_package(root: Path, name: str, files: dict[str, str]) -> Path:
    """A ROS package ``name`` under ``root`` with ``package.xml`` and ``files`` (relative
    path -> text, dedented); returns its folder."""
    import textwrap

    package = root / name
    package.mkdir(parents=True)
    (package / "package.xml").write_text(f'<package format="3"><name>{name}</name></package>\n')
    for relative, text in files.items():
        path = package / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    return package
