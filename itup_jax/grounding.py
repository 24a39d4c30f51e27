"""Grounding an instruction in a scene: which task, which target, which tool, which parts (Omega).

    from itup_jax import grounding
    g = grounding.ground("drive the nail with the hammer", scene)     # the rule grounder
    g.task, g.tool_index, g.work_part, g.grasp_part                  # 'hammer', 0, 'head', 'handle'
    tool = g.grounded_tool(scene)          # the tool with Omega's c_tool and n, and the grasp region
    g = grounding.ground("...", scene, grounder=grounding.VLMGrounder.from_env())   # a vision-language model

Two levels, as in the paper: the **object level** picks the task (its verb and its target: the nail, the
debris, the tower, the block) and the tool; the **part level** picks the tool's working part (where it
touches the target: Omega's c_tool and n) and the part the hand holds (the grasp region). Omega's target
side (c_obj, d) follows from the task kind's placement of its target (`itup_jax.tasks`).

`scene` is anything with `tools` (a sequence of `Tool`) and `targets` (the task targets on the table,
names of TARGETS' values), e.g. a `tabletop.Tabletop`; a plain sequence of tools is a scene with every
target.

The rule grounder (`RuleGrounder`, the default) reads the instruction with a lexicon: task verbs and
target nouns (`TASK_WORDS`), the table's tools by number ("tool 2" / "#2", as `itup run` lists them), by
name ("my_hammer", "spanner@3"), as the user's own ("my hammer", "my tool": a tool loaded from a mesh,
`is_own`) or by category (`TOOL_WORDS`), and part names (`tools.parts.PART_WORDS`). A target noun outweighs a verb ("hit the nail" is the
hammer task, "hit the tower" the knock). With no tool named it takes the scene's first tool of the task
kind's default category, else of a family that does the task (`tools.families.for_task`); with no part named,
the tool's working part and its grasp region. It refuses, with a `GroundingError` naming what it could
not ground, an instruction with no task, an ambiguous one, a target or tool that is not on the table.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Sequence
from typing import Any, Protocol

from itup_jax import tasks
from itup_jax.errors import InputError
from itup_jax.tools import Tool, families, parts


class GroundingError(InputError):
    """The instruction could not be grounded in the scene (the message says what is missing)."""


#: Each task kind's target: the object on the table it acts on.
TARGETS = {"hammer": "nail", "sweep": "debris", "knock": "tower", "reach": "block"}

#: Per task kind, (verbs, target nouns); lower case, a phrase may have several words.
TASK_WORDS = {
    "hammer": (("hammer", "drive", "pound", "nail in", "hammer in", "tap in", "bang in", "strike", "hit"),
               ("nail", "nails", "tack")),
    "sweep": (("sweep", "brush", "clear", "wipe", "push off", "sweep away", "clean"),
              ("debris", "crumbs", "dirt", "cubes", "dust", "mess")),
    "knock": (("knock", "knock over", "topple", "tip over", "push over", "bring down", "knock down", "strike", "hit"),
              ("tower", "stack", "blocks", "pile")),
    "reach": (("reach", "pull", "fetch", "retrieve", "drag", "bring", "get", "hook"),
              ("block", "box", "out of reach", "far block")),
}

#: Words that name a tool of each category (lower case).
TOOL_WORDS = {
    "hammer": ("hammer", "claw hammer"),
    "broom": ("broom", "hand broom", "brush"),
    "mallet": ("mallet",),
    "l_stick": ("l-stick", "l stick", "stick", "hook stick", "l-shaped stick"),
    "screwdriver": ("screwdriver",),
    "spanner": ("spanner", "wrench"),
    "pry_bar": ("pry bar", "prybar", "crowbar", "crow bar", "wrecking bar"),
    "hatchet": ("hatchet", "axe", "ax"),
    "squeegee": ("squeegee",),
}

#: Words before a part's name that make it the part to hold (else it is the working part).
GRASP_CUES = ("by", "hold", "holding", "held", "grip", "gripping", "grasp", "grasping", "grab", "at", "on")


@dataclasses.dataclass(frozen=True)
class Grounding:
    """A grounded instruction.

    Attributes:
      instruction: the instruction as given.
      task: the task kind.
      target: the task's target ('nail', 'debris', 'tower', 'block').
      tool_index: index of the tool in the scene's tools.
      tool_name: that tool's name.
      work_part: the part that touches the target (Omega's c_tool and n).
      grasp_part: the part the hand holds (the grasp region).
      grounder: 'rule', 'vlm' or 'given'.
      notes: what the grounder assumed or could not honour (one sentence each).
    """

    instruction: str
    task: str
    target: str
    tool_index: int
    tool_name: str
    work_part: str
    grasp_part: str
    grounder: str = "rule"
    notes: tuple[str, ...] = ()

    def grounded_tool(self, scene: Any) -> Tool:
        """The scene's grounded tool with the contact of `work_part` and the grasp region of `grasp_part`
        (`tools.parts.apply`)."""
        tool = scene_tools(scene)[self.tool_index]
        return parts.apply(tool, parts.find(tool, self.work_part), parts.find(tool, self.grasp_part))

    def to_json(self) -> dict:
        return {"instruction": self.instruction, "task": self.task, "target": self.target,
                "tool_index": self.tool_index, "tool": self.tool_name, "work_part": self.work_part,
                "grasp_part": self.grasp_part, "grounder": self.grounder, "notes": list(self.notes)}


class Grounder(Protocol):
    """Anything that grounds: `ground(instruction, scene) -> Grounding` (raises GroundingError)."""

    def ground(self, instruction: str, scene: Any) -> Grounding: ...


def scene_tools(scene: Any) -> tuple[Tool, ...]:
    """The scene's tools (a scene's `tools`, or the scene itself when it is a sequence of tools)."""
    tools = getattr(scene, "tools", scene)
    if not isinstance(tools, Sequence) or not tools or not all(isinstance(t, Tool) for t in tools):
        raise InputError("grounding: the scene must have tools (a non-empty sequence of Tool)")
    return tuple(tools)


def scene_targets(scene: Any) -> tuple[str, ...]:
    """The task targets on the scene's table (every target for a plain sequence of tools)."""
    return tuple(getattr(scene, "targets", TARGETS.values()))


def _norm(text: str) -> str:
    return " " + re.sub(r"[^a-z0-9#\-' ]+", " ", text.lower()).replace("'s ", " ").strip() + " "


def _find(text: str, phrase: str) -> list[int]:
    """Start offsets of `phrase` as whole words in the normalised `text`."""
    return [m.start() for m in re.finditer(r"(?<= )" + re.escape(phrase) + r"(?= )", text)]


def _spans(text: str, words: Sequence[str]) -> list[tuple[int, int, str]]:
    out = []
    for w in words:
        out += [(s, s + len(w), w) for s in _find(text, w)]
    return out


def _free(span: tuple[int, int, str], used: list[tuple[int, int]]) -> bool:
    return all(span[1] <= a or span[0] >= b for a, b in used)


def _opening_verb(span: tuple[int, int, str], task_spans: list[tuple[int, int]]) -> bool:
    """Whether a word at `span` opens the instruction inside one of the task's words (its verb)."""
    return span[0] <= 1 and any(a <= span[0] and span[1] <= b for a, b in task_spans)


def _claim(mentions: list[tuple[tuple[int, int, str], Any]], used: list[tuple[int, int]]) -> list:
    """The items of `mentions` [((start, end, phrase), item)] whose words are still free, in the order they
    appear, the longest phrase first where several start together ('claw hammer' over 'hammer'); their
    spans are added to `used`."""
    out = []
    for sp, item in sorted(mentions, key=lambda m: (m[0][0], -(m[0][1] - m[0][0]))):
        if _free(sp, used):
            used.append(sp[:2])
            out.append(item)
    return out


def default_tool_index(task: str, tools: Sequence[Tool]) -> int | None:
    """The scene's tool a task uses when none is named: the first of the kind's default category, else
    the first of a family that does the task (in `tools.families.for_task` order); None when none can."""
    kind = tasks.get(task)
    default_category = {f.name: f.name for f in families.FAMILIES.values()}.get(kind.default_tool, kind.default_tool)
    order = [default_category] + [f for f in families.for_task(task) if f != default_category]
    for cat in order:
        for i, t in enumerate(tools):
            if t.category == cat:
                return i
    return None


@dataclasses.dataclass(frozen=True)
class RuleGrounder:
    """The deterministic lexicon grounder (module docstring)."""

    name: str = "rule"

    def ground(self, instruction: str, scene: Any) -> Grounding:
        if not isinstance(instruction, str) or not instruction.strip():
            raise GroundingError("grounding: the instruction is empty")
        tools, targets = scene_tools(scene), scene_targets(scene)
        text = _norm(instruction)
        used: list[tuple[int, int]] = []
        # object level: the task (target nouns weigh 2, verbs 1)
        score, hits = {}, {}
        for kind, (verbs, nouns) in TASK_WORDS.items():
            if kind not in tasks.names():
                continue
            v, o = _spans(text, verbs), _spans(text, nouns)
            score[kind] = 2 * bool(o) + bool(v)
            hits[kind] = o + v
        best = max(score.values(), default=0)
        if best == 0:
            raise GroundingError(
                f"grounding: no task in {instruction!r}: it names no task verb or target; say e.g. 'drive the "
                "nail', 'sweep the debris', 'knock over the tower', 'pull the block closer'")
        top = sorted(k for k, s in score.items() if s == best)
        if len(top) > 1:
            raise GroundingError(f"grounding: {instruction!r} is ambiguous between the tasks {', '.join(top)}; "
                                 f"name the target ({', '.join(TARGETS[k] for k in top)})")
        task = top[0]
        target = TARGETS[task]
        if target not in targets:
            raise GroundingError(f"grounding: {instruction!r} asks for the {task} task, but there is no {target} "
                                 f"on the table (targets: {', '.join(targets) or 'none'})")
        notes: list[str] = []
        # the tool: a number, else a name or 'my ...', else a category word not used by the task's words,
        # else the default
        tool_index = None
        m = re.search(r"(?:tool|#|number)\s*#?\s*(\d+)", text)
        if m:
            k = int(m.group(1))
            if not 1 <= k <= len(tools):
                raise GroundingError(f"grounding: {instruction!r} names tool {k}, but the table has tools 1-{len(tools)}")
            tool_index = k - 1
            used.append(m.span())
        task_spans = [(a, b) for a, b, _ in hits[task]]
        if tool_index is None:
            tool_index = _tool_by_name(instruction, text, tools, task_spans, used, notes)
        if tool_index is None:
            # a tool word that is also the task's verb and opens the instruction ('hammer the nail') is the
            # verb: with no other tool named, the task's default tool (a hammer) is taken
            cats = _claim([(sp, cat) for cat, words in TOOL_WORDS.items() for sp in _spans(text, words)
                           if not _opening_verb(sp, task_spans)], used)
            if len(set(cats)) > 1:
                raise GroundingError(f"grounding: {instruction!r} names several tools ({', '.join(sorted(set(cats)))}); "
                                     "name one")
            if cats:
                cat = cats[0]
                idx = [i for i, t in enumerate(tools) if t.category == cat]
                if not idx:
                    raise GroundingError(f"grounding: {instruction!r} asks for a {cat.replace('_', ' ')}, but the "
                                         f"table has none (tools: {', '.join(t.name for t in tools)})")
                tool_index = idx[0]
                if len(idx) > 1:
                    notes.append(f"{len(idx)} tools of category {cat!r} on the table; took the first ({tools[idx[0]].name})")
        if tool_index is None:
            tool_index = default_tool_index(task, tools)
            if tool_index is None:
                raise GroundingError(f"grounding: no tool on the table can do the {task} task (tools: "
                                     f"{', '.join(f'{t.name} ({t.category})' for t in tools)}); name one")
            notes.append(f"no tool named: took {tools[tool_index].name}, the first tool for the {task} task")
        tool = tools[tool_index]
        if task not in _category_tasks(tool.category):
            notes.append(f"a {tool.category} is not a tool the {task} task is known to work with")
        used += task_spans
        # part level
        work, grasp = parts.work_part(tool), parts.grasp_parts(tool)[0]
        named_work = named_grasp = None
        for p in parts.tool_parts(tool):
            for sp in sorted(_spans(text, p.words), key=lambda s: -(s[1] - s[0])):
                if not _free(sp, used):
                    continue
                before = text[max(0, sp[0] - 24):sp[0]].split()[-3:]
                if any(w in GRASP_CUES for w in before):
                    named_grasp = p
                else:
                    named_work = p
                used.append(sp[:2])
                break
        if named_work is not None:
            if named_work.contact_points is None:
                notes.append(f"the {named_work.name} has no contact annotation: the work part stays the {work.name}")
            else:
                work = named_work
        if named_grasp is not None:
            grasp = named_grasp
        return Grounding(instruction=instruction, task=task, target=target, tool_index=int(tool_index),
                         tool_name=tool.name, work_part=work.name, grasp_part=grasp.name, grounder=self.name,
                         notes=tuple(notes))


def is_own(tool: Tool) -> bool:
    """Whether `tool` is a user's own (a mesh and spec), not a built-in, family or procedural tool: its name
    is none of theirs ('hammer', 'spanner@3', 'hammer#3', 'hammer~3')."""
    return families.parse_name(tool.name) is None and not re.search(r"[#~]\d+$", tool.name)


#: Words after "my" that mean the user's own tool, whatever it is.
OWN_TOOL_WORDS = ("tool", "own tool")


def _tool_by_name(instruction: str, text: str, tools: Sequence[Tool], task_spans: list, used: list,
                  notes: list) -> int | None:
    """The table's tool the instruction names by its name ('my_hammer', 'spanner@3', as `itup run` lists it)
    or as the user's own ('my hammer', 'my own mallet', 'my tool': `is_own`), or None when it names none
    this way (categories are looked up after). Marks the words it used."""
    # a name that opens the instruction as its verb ('hammer the nail') is the verb; 'my hammer' asks for the
    # user's own hammer, not the built-in tool named 'hammer'
    named = _claim([(sp, i) for i, t in enumerate(tools) for sp in _spans(text, (_norm(t.name).strip(),))
                    if not _opening_verb(sp, task_spans)
                    and (is_own(t) or not text[:sp[0]].endswith(("my ", "my own ")))], used)
    if len(set(named)) > 1:
        raise GroundingError(f"grounding: {instruction!r} names several tools ({', '.join(tools[i].name for i in named)});"
                             " name one")
    if named:
        return named[0]
    own = [i for i, t in enumerate(tools) if is_own(t)]
    for cat, words in (("own", OWN_TOOL_WORDS), *TOOL_WORDS.items()):
        spans = [sp for w in words for sp in _spans(text, (f"my {w}", f"my own {w}")) if _free(sp, used)]
        if not spans:
            continue
        used.append(spans[0][:2])
        idx = [i for i in own if cat == "own" or tools[i].category == cat]
        if not idx:
            yours = ", ".join(f"{tools[i].name} ({tools[i].category})" for i in own) or "none"
            raise GroundingError(f"grounding: {instruction!r} asks for your {'tool' if cat == 'own' else cat.replace('_', ' ')}, "
                                 f"but no tool of yours on the table is {'there' if cat == 'own' else 'one'} (yours: "
                                 f"{yours}; add one as a mesh and spec, `itup run --add-tool MESH SPEC`)")
        if len(idx) > 1:
            notes.append(f"{len(idx)} of your tools fit '{spans[0][2]}'; took the first ({tools[idx[0]].name})")
        return idx[0]
    return None


def _category_tasks(category: str) -> tuple[str, ...]:
    fam = families.FAMILIES.get(category)
    return fam.tasks if fam else ()


def ground(instruction: str, scene: Any, grounder: Any = "rule") -> Grounding:
    """Ground `instruction` in `scene` with `grounder`: 'rule' (`RuleGrounder`), or any object with a
    `ground(instruction, scene)` method (e.g. `vlm.VLMGrounder`)."""
    if grounder == "rule":
        grounder = RuleGrounder()
    if not hasattr(grounder, "ground"):
        raise InputError(f"grounding: grounder must be 'rule' or have a ground(instruction, scene) method, got {grounder!r}")
    return grounder.ground(instruction, scene)


def validate(g: Grounding, scene: Any) -> Grounding:
    """Check a grounding (e.g. a model's answer) against the scene: a known task whose target is on the
    table, a tool index in range, parts the tool has with the right annotation. Returns it with the
    parts' canonical names; GroundingError naming the first problem."""
    tools, targets = scene_tools(scene), scene_targets(scene)
    if g.task not in tasks.names():
        raise GroundingError(f"grounding: unknown task {g.task!r}; known: {', '.join(tasks.names())}")
    if TARGETS.get(g.task) not in targets:
        raise GroundingError(f"grounding: the {g.task} task's target ({TARGETS.get(g.task)}) is not on the table")
    if not isinstance(g.tool_index, int) or not 0 <= g.tool_index < len(tools):
        raise GroundingError(f"grounding: tool index {g.tool_index!r} is not one of the table's 0-{len(tools) - 1}")
    tool = tools[g.tool_index]
    try:
        work, grasp = parts.find(tool, g.work_part), parts.find(tool, g.grasp_part)
    except InputError as exc:
        raise GroundingError(f"grounding: {exc}") from None
    if work.contact_points is None:
        raise GroundingError(f"grounding: the {tool.name}'s {work.name} has no contact annotation (its work part is "
                             f"the {parts.work_part(tool).name})")
    return dataclasses.replace(g, target=TARGETS[g.task], tool_name=tool.name, work_part=work.name,
                               grasp_part=grasp.name)
