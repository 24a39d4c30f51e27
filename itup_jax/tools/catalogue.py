"""What tools there are, in words: the built-in tools, the tool families and the category priors.

    from itup_jax.tools.catalogue import catalogue
    print(catalogue())          # what `itup tools` prints
"""

from __future__ import annotations

import numpy as np

from itup_jax.tools import families, priors
from itup_jax.tools.builtin import BUILTIN_TOOLS
from itup_jax.tools.load import load_tool


def catalogue() -> str:
    """Each built-in tool (category, mass, size, centre of mass, restitution, pad friction, contact duration,
    parts), each tool family (its tasks and default tool) and each category's priors with their sources."""
    lines = []
    for name in BUILTIN_TOOLS:
        t = load_tool(name)
        p = t.params
        lo, hi = t.mesh.bounds
        size = np.round(np.asarray(hi - lo, float), 3).tolist()
        com = np.round(np.asarray(p.com, float), 3).tolist()
        lines.append(f"{name:8s} category {t.category:8s} mass {float(p.mass):.3f} kg  size {size} m  com {com} m  "
                     f"e {float(p.restitution):.2f}  mu {float(p.mu):.2f}  dt {float(p.contact_duration) * 1e3:.0f} ms")
        lines.append(f"{'':8s} parts {list(t.parts)}")
    lines.append("tool families (itup.load_tool('<family>') is the default, '<family>@<seed>' a drawn one):")
    for name in families.names():
        fam = families.get(name)
        t = load_tool(name)
        lo, hi = t.mesh.bounds
        lines.append(f"  {name:12s} tasks {','.join(fam.tasks):12s} default {t.mass:.3f} kg, "
                     f"{float(np.max(hi - lo)):.2f} m long: {fam.summary}")
    lines.append("category priors:")
    for cat, pr in priors.CATEGORY_PRIORS.items():
        for field in ("density", "restitution", "mu", "contact_duration"):
            q = getattr(pr, field)
            lines.append(f"  {cat:11s} {field:16s} {q.value:<8g} {q.unit:7s} {q.source}")
    return "\n".join(lines)
