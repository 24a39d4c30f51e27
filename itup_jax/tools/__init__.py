"""Tools: one home for every tool the planner can hold.

    from itup_jax.tools import load_tool, families
    tool = load_tool("hammer")                        # built-in (`builtin`)
    tool = load_tool("spanner@3")                     # a drawn tool of a family (`families`)
    tool = load_tool("mine.stl", spec="mine.toml")    # a user's mesh and spec (`mesh`)

Modules: `tool` (the `Tool` and its `ToolParams` pytree, mass properties, field checks), `priors`
(materials and per-category priors and frames), `builtin` (the four built-in tools, assembled from
parts), `families` (nine procedural families), `variants` (the training data's procedural variants),
`mesh` (a user's mesh and TOML spec), `parts` (named parts with regions, for grounding), `load`
(`load_tool`).
"""

from itup_jax.tools import families, parts, priors
from itup_jax.tools.builtin import BUILTIN_TOOLS, assemble_tool
from itup_jax.tools.load import load_tool
from itup_jax.tools.mesh import read_tool_spec
from itup_jax.tools.priors import CATEGORY_CONTACT_NORMAL
from itup_jax.tools.tool import Box, Tool, ToolParams, make_tool_params

__all__ = ["BUILTIN_TOOLS", "Box", "CATEGORY_CONTACT_NORMAL", "Tool", "ToolParams", "assemble_tool", "families",
           "load_tool", "make_tool_params", "parts", "priors", "read_tool_spec"]
