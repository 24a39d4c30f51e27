"""Loading a tool by name or from a mesh file: the one door to every tool.

    from itup_jax.tools import load_tool
    load_tool("hammer")                          # a built-in tool
    load_tool("spanner")                         # a tool family's default; "spanner@3": a drawn one
    load_tool("mine.stl", spec="mine.toml")      # a user's mesh and its spec (`tools.mesh`)
"""

from __future__ import annotations

import os
from collections.abc import Mapping

from itup_jax.errors import InputError
from itup_jax.tools import families
from itup_jax.tools.builtin import BUILTIN_TOOLS
from itup_jax.tools.mesh import load_mesh_tool
from itup_jax.tools.tool import Tool

_BUILTIN_CACHE: dict[str, Tool] = {}


def load_tool(name_or_path: str | os.PathLike, spec: str | os.PathLike | Mapping | None = None) -> Tool:
    """Load a built-in tool by name, or a user's tool from a mesh file plus a TOML spec.

    Args:
      name_or_path: a built-in name (`hammer`, `broom`, `mallet`, `l_stick`), a tool family's name
        (`screwdriver`, ...: its default dimensions) or '<family>@<seed>' (a tool drawn from the family,
        `families.draw`), or the path of a mesh file (STL/OBJ/PLY, metres).
      spec: for a mesh file, the path of its TOML spec (or an already-parsed mapping). Fields:
        `name`, `category`, `contact_point` [3], `grasp_region = {min = [3], max = [3]}` (required);
        `contact_normal` [3], `contact_points` [[3], ...], `mass` kg, `density` kg/m^3, `mu`,
        `restitution`, `contact_duration` s (optional; defaults from the category's prior);
        `units` ("m" or "mm": the mesh's and the spec's lengths); `handle_axis` [3] and `x_axis` [3]
        (the file's directions that become the tool frame's +z and +x, when the mesh is not in the
        tool frame; the docs' "Your own tool" has the frame of each category).

    Returns:
      A `Tool`. Built-in and family tools are built once per process and shared.

    Raises:
      InputError: unknown built-in, unreadable/empty/open mesh, a mesh whose size is implausible for
        a hand tool (wrong units), a contact point off the surface, a mesh not in the tool frame without
        a stated frame, malformed spec; the message names the file or field.
    """
    key = os.fspath(name_or_path)
    if spec is None:
        parsed = families.parse_name(key)
        if parsed is not None:
            if key not in _BUILTIN_CACHE:
                family, seed = parsed
                # a built-in tool is its family's default (the registry holds the same builders)
                _BUILTIN_CACHE[key] = families.get(family).build() if seed is None else families.draw(family, seed)
            return _BUILTIN_CACHE[key]
        if os.path.splitext(key)[1]:
            raise InputError(f"tool mesh {key!r}: a mesh file needs a TOML spec (spec=...)")
        raise InputError(f"tool {key!r}: not a built-in tool; built-ins: {', '.join(BUILTIN_TOOLS)}; tool families "
                         f"(their default, or '<family>@<seed>' for a drawn one): {', '.join(families.names())}")
    return load_mesh_tool(key, spec)
