"""Physical priors: materials and the per-category prior table.

Every number carries its unit and either a source or the reason it was chosen. The table is data,
read by `tools.builtin` and `tools.mesh` when a tool is built or loaded; domain randomisation (simulation issue) draws
around these values.

Categories are the tool kinds iTuP knows: the four the built-in tools belong to (hammer -> hammer task,
broom -> sweep, mallet -> knock, l_stick -> reach) and the further procedural families of
`tools.families` (screwdriver, spanner, pry_bar, hatchet, squeegee). A user's mesh names one of them
in its spec and takes its defaults from here. Each category also fixes its tool frame
(`CATEGORY_CONTACT_NORMAL`).
"""

from __future__ import annotations

import dataclasses
from types import MappingProxyType

from itup_jax.errors import InputError


@dataclasses.dataclass(frozen=True)
class Quantity:
    """A prior value with its SI unit and where it comes from."""

    value: float
    unit: str
    source: str


# --- Materials: density in kg/m^3 (handbook values, rounded) --------------------------------------
# Steel: 7850 kg/m^3, the standard value for carbon steel (e.g. EN 1993-1-1, 3.2.6).
# Woods at ~12 % moisture content: USDA Forest Products Laboratory, "Wood Handbook" (2010), ch. 5:
#   hickory ~ 800 kg/m^3 (specific gravity ~0.72-0.75 on green volume), beech ~ 700 kg/m^3.
# Polypropylene ~ 905 kg/m^3, nylon 6,6 ~ 1140 kg/m^3, aluminium ~ 2700 kg/m^3 (handbook values).
# Nylon bristle pack: nylon at an assumed packing fraction of 0.3 (bristles with air between them).
# Cellulose acetate (screwdriver handles) ~ 1300 kg/m^3 (handbook range 1270-1340); polychloroprene
# (neoprene, squeegee blades) ~ 1230 kg/m^3 (handbook value).
MATERIAL_DENSITY = MappingProxyType(
    {
        "steel": 7850.0,
        "hickory": 800.0,
        "beech": 700.0,
        "polypropylene": 905.0,
        "nylon": 1140.0,
        "bristle_pack": 0.3 * 1140.0,
        "aluminium": 2700.0,
        "cellulose_acetate": 1300.0,
        "neoprene": 1230.0,
    }
)


@dataclasses.dataclass(frozen=True)
class CategoryPrior:
    """Prior physical parameters of one tool category.

    Attributes:
      density: effective density used for a single-mesh tool of this category (kg/m^3). Built-in tools
        are assembled from parts with their own materials instead.
      restitution: coefficient of restitution of the tool's contact face against the task target (-).
      mu: Coulomb friction coefficient between the gripper's pads and the tool's grasp region (-).
      contact_duration: duration over which an impulse is delivered (s); F = J / dt.
    """

    density: Quantity
    restitution: Quantity
    mu: Quantity
    contact_duration: Quantity


_PAD_FRICTION_SOURCE = (
    "rubber-like pad on {}: MuJoCo Menagerie's 2F-85 model uses 0.6-0.7 for its pads; "
    "rubber on dry wood/plastic is typically quoted 0.5-0.8; value assumed within that range"
)

CATEGORY_PRIORS = MappingProxyType(
    {
        "hammer": CategoryPrior(
            density=Quantity(
                2000.0, "kg/m^3",
                "effective density of a steel-headed, hickory-handled claw hammer: ~0.5 kg over "
                "~2.5e-4 m^3 of closed volume (built-in hammer's parts)",
            ),
            restitution=Quantity(
                0.4, "-",
                "assumed: steel on steel bounces at 0.6-0.9 between free bodies, but a nail backed "
                "by wood dissipates much of the energy. The analytic impulse and the features use it; the "
                "simulated nail takes the blow plastically (scene.PLASTIC_TARGETS)",
            ),
            mu=Quantity(0.7, "-", _PAD_FRICTION_SOURCE.format("a varnished wood handle")),
            contact_duration=Quantity(
                2e-3, "s",
                "assumed: metal-on-metal impacts last 0.1-1 ms; the nail's travel into the wood "
                "stretches the impulse to a few milliseconds",
            ),
        ),
        "broom": CategoryPrior(
            density=Quantity(
                450.0, "kg/m^3",
                "effective density of a hand broom (plastic handle, wooden block, nylon bristle "
                "pack): ~0.4 kg over ~9e-4 m^3 of closed volume (built-in broom's parts)",
            ),
            restitution=Quantity(
                0.2, "-", "assumed: bristles are compliant and absorb most of an impact's energy"
            ),
            mu=Quantity(0.5, "-", _PAD_FRICTION_SOURCE.format("a smooth polypropylene handle")),
            contact_duration=Quantity(
                20e-3, "s", "assumed: bristles bend over tens of milliseconds when they meet debris"
            ),
        ),
        "mallet": CategoryPrior(
            density=Quantity(700.0, "kg/m^3", "beech, Wood Handbook (see MATERIAL_DENSITY)"),
            restitution=Quantity(
                0.5, "-", "assumed: wood on wood is usually quoted 0.4-0.6"
            ),
            mu=Quantity(0.7, "-", _PAD_FRICTION_SOURCE.format("a wooden handle")),
            contact_duration=Quantity(
                3e-3, "s", "assumed: wood-on-wood impacts last a few milliseconds"
            ),
        ),
        "l_stick": CategoryPrior(
            density=Quantity(2700.0, "kg/m^3", "aluminium rod, handbook value"),
            restitution=Quantity(
                0.3, "-", "assumed: a slow push against a block; little rebound"
            ),
            mu=Quantity(0.6, "-", _PAD_FRICTION_SOURCE.format("an anodised aluminium rod")),
            contact_duration=Quantity(
                50e-3, "s", "assumed: a gentle, quasi-static push builds up over tens of ms"
            ),
        ),
        "screwdriver": CategoryPrior(
            density=Quantity(
                1600.0, "kg/m^3",
                "effective density of a cellulose-acetate handle and a steel shaft: ~0.1 kg over ~6e-5 "
                "m^3 of closed volume (the family's default, `families.screwdriver`)",
            ),
            restitution=Quantity(
                0.5, "-", "assumed: a steel shaft tapping a wooden block, as wood on wood (0.4-0.6)"
            ),
            mu=Quantity(0.5, "-", _PAD_FRICTION_SOURCE.format("a smooth cellulose-acetate handle")),
            contact_duration=Quantity(
                2e-3, "s", "assumed: a stiff steel shaft on wood; between metal-on-metal and wood-on-wood"
            ),
        ),
        "spanner": CategoryPrior(
            density=Quantity(7850.0, "kg/m^3", "solid steel (see MATERIAL_DENSITY)"),
            restitution=Quantity(
                0.4, "-", "assumed as the hammer's: steel on a nail or a wooden block, energy lost into the wood"
            ),
            mu=Quantity(0.5, "-", _PAD_FRICTION_SOURCE.format("a chrome-plated steel bar")),
            contact_duration=Quantity(
                2e-3, "s", "assumed as the hammer's: a steel head on a nail driven into wood"
            ),
        ),
        "pry_bar": CategoryPrior(
            density=Quantity(7850.0, "kg/m^3", "solid steel (see MATERIAL_DENSITY)"),
            restitution=Quantity(
                0.3, "-", "assumed as the L-stick's: a slow push against a block; little rebound"
            ),
            mu=Quantity(0.5, "-", _PAD_FRICTION_SOURCE.format("a painted steel bar")),
            contact_duration=Quantity(
                50e-3, "s", "assumed as the L-stick's: a quasi-static push builds up over tens of ms"
            ),
        ),
        "hatchet": CategoryPrior(
            density=Quantity(
                2750.0, "kg/m^3",
                "effective density of a hickory handle and a steel head: ~0.8 kg over ~2.9e-4 m^3 of "
                "closed volume (the family's default, `families.hatchet`)",
            ),
            restitution=Quantity(
                0.4, "-", "assumed as the hammer's: the steel poll on a nail backed by wood"
            ),
            mu=Quantity(0.7, "-", _PAD_FRICTION_SOURCE.format("a varnished wood handle")),
            contact_duration=Quantity(
                2e-3, "s", "assumed as the hammer's: a steel poll on a nail driven into wood"
            ),
        ),
        "squeegee": CategoryPrior(
            density=Quantity(
                720.0, "kg/m^3",
                "effective density of a neoprene blade, a polypropylene holder and a hollow aluminium "
                "handle: ~0.22 kg over ~3.0e-4 m^3 of closed volume (the family's default, `families.squeegee`)",
            ),
            restitution=Quantity(
                0.1, "-", "assumed: a rubber blade absorbs nearly all of an impact's energy"
            ),
            mu=Quantity(0.5, "-", _PAD_FRICTION_SOURCE.format("an anodised aluminium tube")),
            contact_duration=Quantity(
                20e-3, "s", "assumed as the broom's: a compliant blade deflects over tens of milliseconds"
            ),
        ),
    }
)


def category_prior(category: str, *, what: str = "category") -> CategoryPrior:
    """The prior of `category`; raises `InputError` naming `what` and the known categories."""
    try:
        return CATEGORY_PRIORS[category]
    except (KeyError, TypeError):
        known = ", ".join(sorted(CATEGORY_PRIORS))
        raise InputError(f"{what}: unknown tool category {category!r}; known: {known}") from None


#: The tool frame of each category: the contact normal's direction in it. Every category has the handle
#: along z; hammer, mallet, hatchet, spanner and screwdriver strike with a face (or side) whose normal is
#: +x, the broom and the squeegee push with their head's +y side (the head is wide along x), the L-stick
#: and the pry bar pull with the hook's inner face, which faces back along the handle (-z; the hook itself
#: extends along +x).
CATEGORY_CONTACT_NORMAL = {"hammer": (1.0, 0.0, 0.0), "mallet": (1.0, 0.0, 0.0), "broom": (0.0, 1.0, 0.0),
                           "l_stick": (0.0, 0.0, -1.0), "screwdriver": (1.0, 0.0, 0.0), "spanner": (1.0, 0.0, 0.0),
                           "pry_bar": (0.0, 0.0, -1.0), "hatchet": (1.0, 0.0, 0.0), "squeegee": (0.0, 1.0, 0.0)}
