"""Procedural tool families: parametric builders, their size ranges, and the tasks each can do.

    from itup_jax.tools import families
    families.names()                         # ('hammer', 'broom', ..., 'squeegee', 'baton', ..., 'pusher')
    families.held_out()                      # the five no training set holds
    families.training()                      # the four the shipped network trains on beside the built-ins
    families.calibration()                   # the four the guard is calibrated on
    families.validation()                    # the fifteen of the sealed evaluation's rounds that have run
    families.sealed()                        # the next round's, never rolled out (none until added)
    families.get("screwdriver").tasks        # ('knock',)
    tool = families.draw("spanner", seed=3)  # a random spanner within the family's ranges
    tool = itup.load_tool("spanner@3")       # the same tool by name (the CLI's --tool spanner@3)
    tool = itup.load_tool("spanner")         # the family's default dimensions

Thirty-two families (their builders in `tools.family_shapes`, rounds 4 and 5's in `tools.sealed_shapes`). The first four are the built-in tools'
(`builtin.claw_hammer`, `hand_broom`, `mallet`, `l_stick`), drawn part-wise by `variants.part_variant`.
The next five are held out of every training set (`held_out()`: the evaluations' families the network
never saw), each assembled from primitive parts with their own materials (`builtin.assemble_tool`: mass
properties from the parts' meshes and densities, a watertight union for sampling, capsules and boxes for
the simulator):

  screwdriver  a cellulose-acetate handle and a thin steel shaft; taps with the side of the shaft's tip
               (knock).
  spanner      a flat steel bar with a square head; strikes with the head's side (hammer, knock).
  pry_bar      a heavy steel bar, hexagonal or round, with its end bent at a right angle; hooks and
               pulls with the bend's inner face (reach).
  hatchet      a hickory handle and an asymmetric steel head: a thin blade on one side, a square poll
               on the other; strikes with the poll (hammer, knock).
  squeegee     a T-headed long tool: a neoprene blade in a polypropylene holder on a hollow aluminium
               handle; pushes with the blade (sweep).

The next four are training families (`training()`): wide spans of a built-in category's shape and mass
distribution, each part's material drawn too, made for the network's training data and never used to
evaluate it:

  baton        a headless stick in two coaxial segments (handle and tip, each its radius and material):
               uniform, thin-tipped, heavy- or light-tipped; strikes with the tip's side (mallet's
               category; hammer, knock).
  headed_stick a handle and a box head, light to heavy, centred or lopsided; strikes with the head's face
               (hammer's category; hammer, knock).
  hook         a bar bent at the end, round or square, grasp region up to the bend; pulls with the
               bend (L-stick's category; reach).
  pusher       a T-head, short or wide, on a short or long handle; pushes with the head (broom's
               category; sweep).

The next four are calibration families (`calibration()`): other shapes of the built-in categories, in
no training set, drawn only to calibrate the out-of-distribution guard, so that the five held-out
families stay the set the guard and the network are judged on:

  paddle       a handle and a flat blade, thin along the strike (wood, plastic or aluminium); strikes
               with the blade's face (mallet's category; hammer, knock).
  mace         a handle and a tall box head on its axis, light to heavy; strikes with the head's side
               (hammer's category; hammer, knock).
  scraper      a thin steel or aluminium plate on a short or long handle; pushes with the plate's face
               (broom's category; sweep).
  t_hook       a round bar with a square crossbar across its end, long or short on either side; pulls
               with the crossbar's underside (L-stick's category; reach).

The last eighteen were the sealed-test families of the sealed evaluation's rounds 1 to 6
(`experiments/sealed_eval.py`); all six have run, so they are validation families (`validation()`), looked
at since like the held-out ones and drawn by no later round. Round 1 (the checkpoint shipped with
0.25.0):

  rolling_pin  a handle, a thick barrel and a thin knob past it, of one material; strikes with the
               barrel's side, with mass beyond the contact (mallet's category; hammer, knock).
  rake         a crossbar on three flat tines on a handle; pushes with the tines (broom's category;
               sweep).
  hoe          a round bar with a thin flat blade across its end; pulls with the blade's underside
               (L-stick's category; reach).

Round 2 (0.27.0):

  pick         a handle, a cubic hub and two thin arms out of its sides, much of the head's mass far
               from the handle and little at the striking end; strikes with the front arm's end face
               (hammer's category; hammer, knock).
  offset_pusher  a T-head fixed to its handle off-centre, so the drag twists the handle; pushes with the
               head (broom's category; sweep).
  club         a round bar with a thick block head across its end, heavy where the hoe's blade is thin;
               pulls with the head's underside (L-stick's category; reach).

Round 3 (0.28.0):

  offset_hammer  a handle, a neck out of its top and a round head whose axis lies beside the handle's
               line, so the blow twists the handle about its axis; strikes with the head's end face
               (hammer's category; hammer, knock).
  leaning_broom  a box head and a handle leaning back from the push by 0.1-0.5 rad, as a floor broom's;
               pushes with the head (broom's category; sweep).
  fork_hook    a round bar ending in a crossbar and two parallel prongs; pulls with both prongs' inner
               faces (L-stick's category; reach).

Round 4 (0.29.0; builders in `tools.sealed_shapes`):

  skillet      a handle and a flat round steel or aluminium pan across the strike, most of the mass in a
               wide disc; strikes with the pan's underside (hammer's category; hammer, knock).
  deck_brush   a deep, tall bristle head with the handle rising near its rear edge, so the drag acts
               well ahead of the handle's line; pushes with the head (broom's category; sweep).
  ladle        a round bar with a round bowl on its end; pulls with the bowl's underside (L-stick's
               category; reach).

Round 5 (0.30.0; builders in `tools.sealed_shapes`):

  pommel_hammer  a round head across a handle that stands on a heavy pommel, mass at both ends; strikes
               with the head's end face (hammer's category; hammer, knock).
  angle_broom  a box head turned about the handle's axis, one end of its leading face ahead of the
               other, so the drag lands unevenly and twists the handle; pushes with the head (broom's
               category; sweep).
  cranked_hook a square bar jogged sideways partway up, its hook beside the grasped part's line; pulls
               with the hook's underside (L-stick's category; reach).

Round 6 (0.32.0; builders in `tools.sealed_shapes`):

  cranked_hammer  a round head on a metal shaft cranked forward or back partway up, so the head and the
               blow's line lie ahead of or behind the grasped part's axis in the swing's plane; strikes
               with the head's end face (hammer's category; hammer, knock).
  ballast_broom  a box head with a steel ballast on one side of its top, its mass off the handle's line
               across the push; pushes with the head (broom's category; sweep).
  tapered_hook a pole tapering in three sections from a thick butt to a thin tip and a square hook,
               aluminium or hickory, the hook aluminium or steel; pulls with the hook's underside
               (L-stick's category; reach).

Every family keeps its category's tool frame (`priors.CATEGORY_CONTACT_NORMAL`): the handle along +z
from its butt at the origin (the leaning broom's leans from +z), the contact normal along the category's
direction. The ranges are typical
hand-tool dimensions (assumed); every draw inside them builds a closed mesh with positive inertia, and
its contact lands on the task's target (tests/test_families.py).
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable, Mapping
from types import MappingProxyType

import numpy as np

from itup_jax.errors import InputError
from itup_jax.tools.builtin import claw_hammer, hand_broom, l_stick, mallet
from itup_jax.tools.family_shapes import (
    HANDLE_MATERIALS,
    HEAD_MATERIALS,
    baton,
    club,
    fork_hook,
    hatchet,
    headed_stick,
    hoe,
    hook,
    leaning_broom,
    mace,
    offset_hammer,
    offset_pusher,
    paddle,
    pick,
    pry_bar,
    pusher,
    rake,
    rolling_pin,
    scraper,
    screwdriver,
    spanner,
    squeegee,
    t_hook,
)
from itup_jax.tools.sealed_shapes import (
    angle_broom,
    ballast_broom,
    cranked_hammer,
    cranked_hook,
    deck_brush,
    ladle,
    pommel_hammer,
    skillet,
    tapered_hook,
)
from itup_jax.tools.tool import Tool
from itup_jax.tools.variants import part_variant

# ---------------------------------------------------------------------------------------------------
# The registry
# ---------------------------------------------------------------------------------------------------
#: What a family is for (`Family.role`).
ROLES = ("builtin", "held_out", "training", "calibration", "validation", "sealed")


@dataclasses.dataclass(frozen=True)
class Family:
    """One procedural tool family.

    Attributes:
      name: the family's name (`load_tool`'s name for the default; its tools' category unless `category`).
      build: keyword dimensions (metres) -> Tool; its defaults are the family's default tool.
      tasks: the task kinds the family's tools can do.
      ranges: {keyword: (low, high)} uniform ranges of a draw (metres, or a count for `sections`);
        empty for the four built-in families, which `variants.part_variant` draws.
      choices: {keyword: (value, ...)} discrete choices of a draw (uniform).
      summary: one line for the docs and `itup tools`.
      role: what the family is for (`ROLES`):
        "builtin": one of the four families of the built-in tools (no `ranges`: `variants.part_variant`
          draws them);
        "held_out": kept out of every training set, the evaluations' unseen families;
        "training": a wide span of a category's shapes and mass distributions, drawn for the network's
          training data (`itup generate --family`), never for its evaluation;
        "calibration": a category's shape that no training set holds, drawn to calibrate the
          out-of-distribution guard (`experiments/ood_guard.py --calibrate-on calibration`), never to
          train or to judge the network;
        "validation": the sealed-test families of a sealed evaluation that has run: never trained on,
          looked at since, and drawn by no later sealed evaluation;
        "sealed": added for the next sealed evaluation (`experiments/sealed_eval.py`), never rolled
          out before it; "validation" once that evaluation has run.
      category: its tools' category (priors and tool frame), when not the family's name.
    """

    name: str
    build: Callable[..., Tool]
    tasks: tuple[str, ...]
    ranges: Mapping[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    choices: Mapping[str, tuple] = dataclasses.field(default_factory=dict)
    summary: str = ""
    role: str = "held_out"
    category: str = ""

    def __post_init__(self):
        if self.role not in ROLES:
            raise ValueError(f"family {self.name!r}: role {self.role!r} is not one of {ROLES}")
        if (self.role == "builtin") != (not self.ranges):
            raise ValueError(f"family {self.name!r}: the built-in families, and only they, have no ranges")

    @property
    def builtin(self) -> bool:
        """One of the four families of the built-in tools (drawn by `variants.part_variant`)."""
        return self.role == "builtin"

    @property
    def held_out(self) -> bool:
        """One of the five families kept out of every training set: the evaluation's unseen families."""
        return self.role == "held_out"

    @property
    def training(self) -> bool:
        """A training family (role "training")."""
        return self.role == "training"

    @property
    def calibration(self) -> bool:
        """A calibration family (role "calibration")."""
        return self.role == "calibration"

    @property
    def validation(self) -> bool:
        """A family of an earlier sealed evaluation (role "validation")."""
        return self.role == "validation"

    @property
    def sealed(self) -> bool:
        """A sealed-test family (role "sealed")."""
        return self.role == "sealed"

    @property
    def tool_category(self) -> str:
        """The category of the family's tools."""
        return self.category or self.name


def _ranges(**r: tuple[float, float]) -> Mapping[str, tuple[float, float]]:
    return MappingProxyType(r)


FAMILIES: Mapping[str, Family] = MappingProxyType({
    "hammer": Family("hammer", claw_hammer, ("hammer",), summary="claw hammer (built-in; part-wise variants)",
                       role="builtin"),
    "broom": Family("broom", hand_broom, ("sweep",), summary="hand broom (built-in; part-wise variants)",
                      role="builtin"),
    "mallet": Family("mallet", mallet, ("knock",), summary="wooden mallet (built-in; part-wise variants)",
                       role="builtin"),
    "l_stick": Family("l_stick", l_stick, ("reach",), summary="L-shaped aluminium stick (built-in; part-wise variants)",
                        role="builtin"),
    "screwdriver": Family(
        "screwdriver", screwdriver, ("knock",),
        _ranges(handle_radius=(0.011, 0.018), handle_length=(0.080, 0.130), shaft_radius=(0.0025, 0.004),
                shaft_length=(0.075, 0.200)),
        summary="handle and thin steel shaft; taps with the shaft's side"),
    "spanner": Family(
        "spanner", spanner, ("hammer", "knock"),
        _ranges(bar_length=(0.120, 0.240), bar_width=(0.014, 0.026), bar_thickness=(0.004, 0.007),
                head_half=(0.014, 0.026), head_thickness=(0.006, 0.012)),
        summary="flat steel bar and square head; strikes with the head's side"),
    "pry_bar": Family(
        "pry_bar", pry_bar, ("reach",),
        _ranges(length=(0.350, 0.600), radius=(0.007, 0.011), hook_end=(0.060, 0.110)),
        MappingProxyType({"sections": (6, 48)}),
        summary="heavy steel bar (hexagonal or round) bent at the end; hooks with the bend"),
    "hatchet": Family(
        "hatchet", hatchet, ("hammer", "knock"),
        _ranges(handle_length=(0.250, 0.380), handle_radius=(0.013, 0.018), blade_length=(0.070, 0.110),
                blade_height=(0.060, 0.100), blade_thickness=(0.006, 0.010), poll_length=(0.020, 0.040),
                poll_size=(0.022, 0.034)),
        summary="handle and asymmetric steel head (blade and poll); strikes with the poll"),
    "squeegee": Family(
        "squeegee", squeegee, ("sweep",),
        _ranges(half_width=(0.100, 0.200), blade_height=(0.020, 0.040), handle_radius=(0.009, 0.013),
                handle_length=(0.300, 0.500)),
        summary="T-headed long tool: blade on a long handle; pushes with the blade"),
    "baton": Family(
        "baton", baton, ("hammer", "knock"),
        _ranges(length=(0.180, 0.450), handle_fraction=(0.35, 0.75), handle_radius=(0.010, 0.018),
                tip_radius=(0.003, 0.020)),
        MappingProxyType({"handle_material": HANDLE_MATERIALS, "tip_material": HEAD_MATERIALS}),
        summary="training: headless two-segment stick, thin or thick, light or heavy tip; strikes with the tip's side",
        role="training", category="mallet"),
    "headed_stick": Family(
        "headed_stick", headed_stick, ("hammer", "knock"),
        _ranges(handle_length=(0.180, 0.450), handle_radius=(0.010, 0.018), head_back=(0.010, 0.070),
                head_front=(0.015, 0.070), head_height=(0.018, 0.045), head_width=(0.012, 0.040)),
        MappingProxyType({"handle_material": HANDLE_MATERIALS, "head_material": HEAD_MATERIALS}),
        summary="training: handle and box head, light to heavy, centred or lopsided; strikes with the head",
        role="training", category="hammer"),
    "hook": Family(
        "hook", hook, ("reach",),
        _ranges(length=(0.300, 0.600), radius=(0.005, 0.010), hook_end=(0.050, 0.140), grasp_fraction=(0.3, 0.95)),
        MappingProxyType({"material": ("aluminium", "steel", "hickory", "polypropylene"),
                          "section": ("round", "square")}),
        summary="training: bar bent at the end, grasp region up to the bend; hooks with the bend",
        role="training", category="l_stick"),
    "pusher": Family(
        "pusher", pusher, ("sweep",),
        _ranges(half_width=(0.040, 0.220), head_height=(0.020, 0.060), head_depth=(0.015, 0.050),
                handle_radius=(0.008, 0.014), handle_length=(0.120, 0.550), grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"head_material": ("beech", "polypropylene", "neoprene"), "handle_material": HANDLE_MATERIALS}),
        summary="training: T-head short or wide on a short or long handle; pushes with the head",
        role="training", category="broom"),
    "paddle": Family(
        "paddle", paddle, ("hammer", "knock"),
        _ranges(handle_length=(0.120, 0.300), handle_radius=(0.010, 0.016), blade_thickness=(0.006, 0.020),
                blade_width=(0.040, 0.120), blade_height=(0.060, 0.200)),
        MappingProxyType({"handle_material": HANDLE_MATERIALS,
                          "blade_material": ("beech", "hickory", "polypropylene", "aluminium")}),
        summary="calibration: handle and flat blade; strikes with the blade's face",
        role="calibration", category="mallet"),
    "mace": Family(
        "mace", mace, ("hammer", "knock"),
        _ranges(handle_length=(0.180, 0.400), handle_radius=(0.010, 0.017), head_half_x=(0.010, 0.025),
                head_half_y=(0.010, 0.025), head_height=(0.030, 0.080)),
        MappingProxyType({"handle_material": HANDLE_MATERIALS, "head_material": HEAD_MATERIALS}),
        summary="calibration: handle and tall box head on its axis; strikes with the head's side",
        role="calibration", category="hammer"),
    "scraper": Family(
        "scraper", scraper, ("sweep",),
        _ranges(half_width=(0.050, 0.180), blade_height=(0.030, 0.080), blade_thickness=(0.0015, 0.003),
                handle_radius=(0.008, 0.014), handle_length=(0.150, 0.500)),
        MappingProxyType({"blade_material": ("steel", "aluminium"), "handle_material": HANDLE_MATERIALS}),
        summary="calibration: thin metal plate on a handle; pushes with the plate's face",
        role="calibration", category="broom"),
    "t_hook": Family(
        "t_hook", t_hook, ("reach",),
        _ranges(length=(0.300, 0.550), radius=(0.005, 0.010), bar_half=(0.005, 0.010), front=(0.050, 0.130),
                back=(0.020, 0.080), grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"material": ("aluminium", "steel", "hickory", "polypropylene")}),
        summary="calibration: bar with a square crossbar on its end; pulls with the crossbar",
        role="calibration", category="l_stick"),
    "rolling_pin": Family(
        "rolling_pin", rolling_pin, ("hammer", "knock"),
        _ranges(handle_length=(0.080, 0.150), handle_radius=(0.010, 0.015), barrel_length=(0.120, 0.250),
                barrel_radius=(0.018, 0.032), knob_length=(0.030, 0.100)),
        MappingProxyType({"material": ("beech", "hickory", "polypropylene", "nylon")}),
        summary="validation (sealed test, round 1): handle, thick barrel and knob; strikes with the barrel's side",
        role="validation", category="mallet"),
    "rake": Family(
        "rake", rake, ("sweep",),
        _ranges(half_width=(0.080, 0.200), bar_depth=(0.010, 0.025), bar_height=(0.010, 0.025),
                tine_length=(0.030, 0.080), tine_width=(0.006, 0.012), tine_thickness=(0.002, 0.004),
                handle_radius=(0.008, 0.014), handle_length=(0.200, 0.500)),
        MappingProxyType({"head_material": ("aluminium", "polypropylene", "beech"), "handle_material": HANDLE_MATERIALS}),
        summary="validation (sealed test, round 1): crossbar on three flat tines, on a handle; pushes with the tines",
        role="validation", category="broom"),
    "hoe": Family(
        "hoe", hoe, ("reach",),
        _ranges(length=(0.300, 0.550), radius=(0.005, 0.010), blade_end=(0.050, 0.120),
                blade_half_width=(0.015, 0.050), blade_thickness=(0.002, 0.006), grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"bar_material": ("aluminium", "hickory", "steel"), "blade_material": ("steel", "aluminium")}),
        summary="validation (sealed test, round 1): bar with a flat blade across its end; pulls with the blade's "
                "underside",
        role="validation", category="l_stick"),
    "pick": Family(
        "pick", pick, ("hammer", "knock"),
        _ranges(handle_length=(0.220, 0.400), handle_radius=(0.011, 0.017), hub=(0.022, 0.040), front=(0.050, 0.150),
                back=(0.030, 0.140), arm_thickness=(0.008, 0.018), arm_width=(0.010, 0.022)),
        MappingProxyType({"handle_material": HANDLE_MATERIALS, "head_material": ("steel", "aluminium")}),
        summary="validation (sealed test, round 2): handle, hub and two thin arms; strikes with the front arm's end",
        role="validation", category="hammer"),
    "offset_pusher": Family(
        "offset_pusher", offset_pusher, ("sweep",),
        _ranges(half_width=(0.060, 0.160), offset=(0.030, 0.120), head_height=(0.020, 0.050),
                head_depth=(0.015, 0.040), handle_radius=(0.009, 0.014), handle_length=(0.200, 0.550),
                grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"head_material": ("beech", "polypropylene", "aluminium"), "handle_material": HANDLE_MATERIALS}),
        summary="validation (sealed test, round 2): T-head fixed to its handle off-centre; pushes with the head",
        role="validation", category="broom"),
    "club": Family(
        "club", club, ("reach",),
        _ranges(length=(0.300, 0.550), radius=(0.005, 0.010), head_front=(0.040, 0.090), head_back=(0.000, 0.030),
                head_half_width=(0.012, 0.030), head_thickness=(0.018, 0.045), grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"bar_material": ("aluminium", "hickory", "steel"), "head_material": ("steel", "aluminium", "beech")}),
        summary="validation (sealed test, round 2): bar with a thick block head across its end; pulls with the head's underside",
        role="validation", category="l_stick"),
    "offset_hammer": Family(
        "offset_hammer", offset_hammer, ("hammer", "knock"),
        _ranges(handle_length=(0.220, 0.380), handle_radius=(0.011, 0.017), offset=(0.020, 0.070),
                head_radius=(0.010, 0.020), head_front=(0.030, 0.070), head_back=(0.020, 0.060)),
        MappingProxyType({"handle_material": HANDLE_MATERIALS, "head_material": ("steel", "aluminium")}),
        summary="validation (sealed test, round 3): handle and round head beside its line on a neck; strikes with the head's end face",
        role="validation", category="hammer"),
    "leaning_broom": Family(
        "leaning_broom", leaning_broom, ("sweep",),
        _ranges(half_width=(0.080, 0.200), head_height=(0.025, 0.060), head_depth=(0.020, 0.050),
                handle_radius=(0.009, 0.014), handle_length=(0.250, 0.550), lean=(0.10, 0.50),
                grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"head_material": ("beech", "polypropylene", "nylon"), "handle_material": HANDLE_MATERIALS}),
        summary="validation (sealed test, round 3): box head and a handle leaning back from the push; pushes with the head",
        role="validation", category="broom"),
    "fork_hook": Family(
        "fork_hook", fork_hook, ("reach",),
        _ranges(length=(0.300, 0.550), radius=(0.004, 0.008), spread=(0.015, 0.045), hook_end=(0.050, 0.110),
                grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"material": ("aluminium", "steel", "hickory")}),
        summary="validation (sealed test, round 3): bar ending in a crossbar and two parallel prongs; pulls with both prongs",
        role="validation", category="l_stick"),
    "skillet": Family(
        "skillet", skillet, ("hammer", "knock"),
        _ranges(handle_length=(0.140, 0.260), handle_radius=(0.010, 0.016), pan_radius=(0.050, 0.090),
                pan_thickness=(0.003, 0.006)),
        MappingProxyType({"handle_material": HANDLE_MATERIALS, "pan_material": ("steel", "aluminium")}),
        summary="validation (sealed test, round 4): handle and a flat round pan across the strike; strikes with the pan's underside",
        role="validation", category="hammer"),
    "deck_brush": Family(
        "deck_brush", deck_brush, ("sweep",),
        _ranges(half_width=(0.060, 0.140), front=(0.045, 0.090), back=(0.014, 0.025), head_height=(0.065, 0.090),
                handle_radius=(0.009, 0.014), handle_length=(0.250, 0.550), grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"handle_material": HANDLE_MATERIALS}),
        summary="validation (sealed test, round 4): deep head with the handle at its rear; pushes with the head's leading face",
        role="validation", category="broom"),
    "ladle": Family(
        "ladle", ladle, ("reach",),
        _ranges(length=(0.300, 0.550), radius=(0.005, 0.009), bowl_radius=(0.025, 0.045), bowl_thickness=(0.006, 0.012),
                grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"bar_material": ("aluminium", "steel", "hickory"),
                          "bowl_material": ("steel", "aluminium", "polypropylene")}),
        summary="validation (sealed test, round 4): bar with a round bowl on its end; pulls with the bowl's underside",
        role="validation", category="l_stick"),
    "pommel_hammer": Family(
        "pommel_hammer", pommel_hammer, ("hammer", "knock"),
        _ranges(handle_length=(0.200, 0.320), handle_radius=(0.011, 0.016), head_radius=(0.011, 0.018),
                head_front=(0.030, 0.060), head_back=(0.020, 0.060), pommel_radius=(0.016, 0.026),
                pommel_length=(0.015, 0.045)),
        MappingProxyType({"handle_material": HANDLE_MATERIALS, "pommel_material": ("steel", "aluminium")}),
        summary="validation (sealed test, round 5): round head across a handle on a heavy pommel; strikes with the head's end face",
        role="validation", category="hammer"),
    "angle_broom": Family(
        "angle_broom", angle_broom, ("sweep",),
        _ranges(half_width=(0.070, 0.150), head_depth=(0.020, 0.045), head_height=(0.030, 0.060), yaw=(0.05, 0.14),
                handle_radius=(0.009, 0.014), handle_length=(0.250, 0.550), grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"head_material": ("beech", "polypropylene", "nylon"), "handle_material": HANDLE_MATERIALS}),
        summary="validation (sealed test, round 5): box head turned about the handle's axis; pushes with its leading face",
        role="validation", category="broom"),
    "cranked_hook": Family(
        "cranked_hook", cranked_hook, ("reach",),
        _ranges(length=(0.300, 0.550), half=(0.005, 0.009), jog=(0.025, 0.070), jog_at=(0.5, 0.7),
                hook_end=(0.050, 0.100), grasp_fraction=(0.5, 0.9)),
        MappingProxyType({"material": ("aluminium", "steel", "hickory")}),
        summary="validation (sealed test, round 5): square bar jogged sideways, its hook beside the grasped part's line; pulls with the hook",
        role="validation", category="l_stick"),
    "cranked_hammer": Family(
        "cranked_hammer", cranked_hammer, ("hammer", "knock"),
        _ranges(length=(0.220, 0.320), radius=(0.008, 0.011), crank_at=(0.45, 0.65), jog=(-0.040, 0.060),
                head_radius=(0.011, 0.017), head_front=(0.030, 0.055), head_back=(0.020, 0.045)),
        MappingProxyType({"shaft_material": ("aluminium", "steel")}),
        summary="validation (sealed test, round 6): round head on a shaft cranked forward or back in the swing's plane; strikes with the head's end face",
        role="validation", category="hammer"),
    "ballast_broom": Family(
        "ballast_broom", ballast_broom, ("sweep",),
        _ranges(half_width=(0.070, 0.150), head_depth=(0.025, 0.050), head_height=(0.030, 0.055),
                ballast_from=(0.015, 0.050), ballast_length=(0.030, 0.080), ballast_height=(0.008, 0.020),
                handle_radius=(0.009, 0.014), handle_length=(0.250, 0.550), grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"head_material": ("beech", "polypropylene", "nylon"), "handle_material": HANDLE_MATERIALS}),
        summary="validation (sealed test, round 6): box head with a steel ballast on one side of its top; pushes with its leading face",
        role="validation", category="broom"),
    "tapered_hook": Family(
        "tapered_hook", tapered_hook, ("reach",),
        _ranges(length=(0.300, 0.550), butt_radius=(0.010, 0.015), tip_radius=(0.005, 0.008), butt_fraction=(0.3, 0.5),
                hook_end=(0.050, 0.100), grasp_fraction=(0.5, 0.9)),
        MappingProxyType({"material": ("aluminium", "hickory"), "hook_material": ("aluminium", "steel")}),
        summary="validation (sealed test, round 6): pole tapering from a thick butt to a square hook; pulls with the hook's underside",
        role="validation", category="l_stick"),
})


def names() -> tuple[str, ...]:
    """The families: the four built-in ones, the five held-out ones, the training families, the
    calibration families, then the sealed evaluation's rounds' families (validation once a round has
    run)."""
    return tuple(FAMILIES)


def with_role(role: str) -> tuple[str, ...]:
    """The families of `role` (`ROLES`), in `names()` order."""
    if role not in ROLES:
        raise InputError(f"family role {role!r}: unknown; known: {', '.join(ROLES)}")
    return tuple(f.name for f in FAMILIES.values() if f.role == role)


def held_out() -> tuple[str, ...]:
    """The five families no training set holds (the evaluations' unseen families)."""
    return with_role("held_out")


def training() -> tuple[str, ...]:
    """The training families."""
    return with_role("training")


def calibration() -> tuple[str, ...]:
    """The calibration families."""
    return with_role("calibration")


def validation() -> tuple[str, ...]:
    """The sealed-test families of the sealed evaluations that have run."""
    return with_role("validation")


def sealed() -> tuple[str, ...]:
    """The sealed-test families of the next sealed evaluation's round (none until one is added)."""
    return with_role("sealed")


def get(name: str) -> Family:
    """The family `name`, or InputError naming the known ones."""
    try:
        return FAMILIES[name]
    except (KeyError, TypeError):
        raise InputError(f"tool family {name!r}: unknown; known: {', '.join(FAMILIES)}") from None


def for_task(kind: str) -> tuple[str, ...]:
    """The families whose tools can do task `kind`."""
    return tuple(f.name for f in FAMILIES.values() if kind in f.tasks)


def draw(name: str, seed: int) -> Tool:
    """A tool of family `name` drawn with `seed` (the same tool for the same seed), named '<name>@<seed>'.
    The nine families defined here (held-out and training) draw every dimension uniformly in its range
    (and each choice uniformly); the four built-in families draw their part-wise variants
    (`variants.part_variant`)."""
    fam = get(name)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"families.draw({name!r}): seed must be an integer >= 0, got {seed!r}")
    if fam.builtin:
        return dataclasses.replace(part_variant(name, int(seed)), name=f"{name}@{int(seed)}")
    rng = np.random.default_rng([int(seed), sum(map(ord, name))])
    kw = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in fam.ranges.items()}
    kw.update({k: v[int(rng.integers(len(v)))] for k, v in fam.choices.items()})
    return fam.build(name=f"{name}@{int(seed)}", **kw)


_DRAWN = re.compile(r"^([a-z_]+)@(\d+)$")


def parse_name(name: str) -> tuple[str, int | None] | None:
    """('<family>', seed) for '<family>@<seed>', ('<family>', None) for a family's name, None otherwise."""
    if name in FAMILIES:
        return name, None
    m = _DRAWN.match(name)
    if m and m.group(1) in FAMILIES:
        return m.group(1), int(m.group(2))
    return None
