"""Grounding with a vision-language model behind any OpenAI-compatible chat endpoint.

    from itup_jax.vlm import VLMGrounder
    g = VLMGrounder(url="http://localhost:8000/v1", model="qwen2.5-vl-7b")      # key from $OPENAI_API_KEY
    grounding = itup.run("drive the nail", grounder=g).grounding
    itup run "drive the nail" --grounder vlm --vlm-url http://localhost:8000/v1 --vlm-model qwen2.5-vl-7b

The adapter sends one chat completion (`POST <url>/chat/completions`): a system message that asks for a
JSON object, and a user message with the instruction, the table's tools by number with their parts by
letter ("2b": tool 2's second part) and the targets on the table, plus the table's picture
(`tabletop.picture`: MuJoCo's offscreen rendering where OpenGL works, else the top view; numbered tools,
lettered parts) as a base64 PNG `image_url`. The answer must be a
JSON object {"task": <task kind>, "tool": <tool number>, "work_part": <part name or letter>,
"grasp_part": <part name or letter>}; it is checked against the scene (`grounding.validate`).

Failures are `VLMError` (a `GroundingError`) with a message naming what went wrong: the endpoint cannot
be reached, it answers with an HTTP error or not in time (`timeout` s), the model refuses (a `refusal`
in the message, or an answer with "refuse"/"cannot" and no JSON), the answer is not the JSON object
asked for, or it names a task, tool or part the table does not have. With `fallback="rule"` any of these
falls back to the rule grounder and the grounding's notes say why. Nothing is sent anywhere unless a
user constructs a `VLMGrounder` with a URL; the key is read from the environment variable `api_key_env`
(unset: no Authorization header, as local servers accept).
"""

from __future__ import annotations

import base64
import dataclasses
import io
import json
import os
import re
import socket
import urllib.error
import urllib.request
from typing import Any

from itup_jax.grounding import Grounding, GroundingError, RuleGrounder, scene_targets, scene_tools, validate
from itup_jax.tasks import names as task_names
from itup_jax.tools import parts

SYSTEM_PROMPT = (
    "You ground a robot tool-use instruction in a table scene. The picture shows the table: "
    "tools are numbered, their parts lettered (2b is tool 2's part b), the targets are marked. Answer with "
    "one JSON object and nothing else: {\"task\": one of %s, \"tool\": the number of the tool to use, "
    "\"work_part\": the name or letter of the part that touches the target, \"grasp_part\": the name or "
    "letter of the part the gripper should hold}.")
#: Environment variables `VLMGrounder.from_env` reads.
ENV_URL, ENV_MODEL, ENV_KEY = "ITUP_VLM_URL", "ITUP_VLM_MODEL", "ITUP_VLM_KEY_ENV"


class VLMError(GroundingError):
    """The vision-language grounder failed (the message says how)."""


def describe(scene: Any) -> str:
    """The scene as text: numbered tools with their lettered parts (and roles), and the targets."""
    lines = []
    for i, t in enumerate(scene_tools(scene)):
        ps = ", ".join(f"{i + 1}{chr(97 + k)} {p.name}" + (f" ({'/'.join(p.roles)})" if p.roles else "")
                       for k, p in enumerate(parts.tool_parts(t)))
        lines.append(f"tool {i + 1}: {t.category.replace('_', ' ')} '{t.name}'; parts: {ps}")
    lines.append("targets on the table: " + ", ".join(scene_targets(scene)))
    return "\n".join(lines)


def _image_png(scene: Any, view: str) -> bytes:
    from itup_jax.tabletop import Tabletop, picture

    if not isinstance(scene, Tabletop):
        return b""
    import matplotlib.pyplot as plt

    fig = picture(scene, view=view)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return buf.getvalue()


def _part_name(value: Any, tool_number: int, tool) -> str:
    """A part given by name or by letter ('b' or '2b') -> its name."""
    s = str(value).strip().lower()
    m = re.fullmatch(r"(\d+)?([a-z])", s)
    if m:
        if m.group(1) and int(m.group(1)) != tool_number:
            raise VLMError(f"vlm grounding: part {value!r} belongs to tool {m.group(1)}, not to the chosen tool {tool_number}")
        ps = parts.tool_parts(tool)
        k = ord(m.group(2)) - 97
        if not 0 <= k < len(ps):
            raise VLMError(f"vlm grounding: tool {tool_number} has no part {value!r} (parts a-{chr(96 + len(ps))})")
        return ps[k].name
    return s


@dataclasses.dataclass(frozen=True)
class VLMGrounder:
    """A grounder that asks a vision-language model (module docstring).

    Attributes:
      url: the API's base URL (the part before /chat/completions), e.g. http://localhost:8000/v1.
      model: the model's name on that endpoint.
      api_key_env: the environment variable holding the API key (unset: no key sent).
      timeout: s, how long to wait for the answer.
      fallback: None (fail with VLMError) or 'rule' (use the rule grounder, noting why).
      image: send the table's picture (a model without vision may take the text alone).
      view: the picture's view (`tabletop.picture`: 'auto', 'camera' or 'top').
    """

    url: str
    model: str
    api_key_env: str = "OPENAI_API_KEY"
    timeout: float = 60.0
    fallback: str | None = None
    image: bool = True
    view: str = "auto"
    name: str = "vlm"

    def __post_init__(self):
        if not isinstance(self.url, str) or not re.match(r"^https?://", self.url):
            raise VLMError(f"vlm grounding: url must start with http:// or https://, got {self.url!r}")
        if not isinstance(self.model, str) or not self.model:
            raise VLMError("vlm grounding: model must be a non-empty string (the endpoint's model name)")
        if not (isinstance(self.timeout, (int, float)) and self.timeout > 0):
            raise VLMError(f"vlm grounding: timeout must be a positive number of seconds, got {self.timeout!r}")
        if self.fallback not in (None, "rule"):
            raise VLMError(f"vlm grounding: fallback must be None or 'rule', got {self.fallback!r}")
        from itup_jax.tabletop import VIEWS

        if self.view not in VIEWS:
            raise VLMError(f"vlm grounding: view must be one of {', '.join(VIEWS)}, got {self.view!r}")

    @classmethod
    def from_env(cls, **kw) -> "VLMGrounder":
        """A grounder configured by $ITUP_VLM_URL, $ITUP_VLM_MODEL and (optionally) $ITUP_VLM_KEY_ENV."""
        url, model = os.environ.get(ENV_URL), os.environ.get(ENV_MODEL)
        if not url or not model:
            raise VLMError(f"vlm grounding: set {ENV_URL} and {ENV_MODEL} (or pass url and model)")
        if os.environ.get(ENV_KEY):
            kw.setdefault("api_key_env", os.environ[ENV_KEY])
        return cls(url=url, model=model, **kw)

    def request_body(self, instruction: str, scene: Any) -> dict:
        """The chat-completion request (JSON body) for `instruction` in `scene`."""
        text = f"Instruction: {instruction}\n\n{describe(scene)}"
        content: list[dict] = [{"type": "text", "text": text}]
        png = _image_png(scene, self.view) if self.image else b""
        if png:
            content.append({"type": "image_url",
                            "image_url": {"url": "data:image/png;base64," + base64.b64encode(png).decode()}})
        return {"model": self.model, "temperature": 0,
                "messages": [{"role": "system", "content": SYSTEM_PROMPT % ", ".join(task_names())},
                             {"role": "user", "content": content}]}

    def _post(self, body: dict) -> dict:
        url = self.url.rstrip("/") + "/chat/completions"
        headers = {"Content-Type": "application/json"}
        key = os.environ.get(self.api_key_env)
        if key:
            headers["Authorization"] = f"Bearer {key}"
        req = urllib.request.Request(url, data=json.dumps(body).encode(), headers=headers, method="POST")
        try:
            with urllib.request.urlopen(req, timeout=self.timeout) as resp:
                raw = resp.read()
        except urllib.error.HTTPError as exc:
            detail = exc.read()[:300].decode("utf-8", "replace")
            raise VLMError(f"vlm grounding: {url} answered HTTP {exc.code}: {detail}") from None
        except (TimeoutError, socket.timeout):
            raise VLMError(f"vlm grounding: no answer from {url} within {self.timeout:g} s") from None
        except urllib.error.URLError as exc:
            if isinstance(exc.reason, (TimeoutError, socket.timeout)):
                raise VLMError(f"vlm grounding: no answer from {url} within {self.timeout:g} s") from None
            raise VLMError(f"vlm grounding: cannot reach {url}: {exc.reason}") from None
        try:
            return json.loads(raw)
        except ValueError:
            raise VLMError(f"vlm grounding: {url} did not answer with JSON: {raw[:200]!r}") from None

    def _answer(self, reply: dict) -> dict:
        try:
            msg = reply["choices"][0]["message"]
        except (KeyError, IndexError, TypeError):
            raise VLMError(f"vlm grounding: the reply has no choices[0].message: {str(reply)[:200]}") from None
        if msg.get("refusal"):
            raise VLMError(f"vlm grounding: the model refused: {msg['refusal']}")
        content = msg.get("content")
        if isinstance(content, list):  # a list of content parts
            content = "".join(p.get("text", "") for p in content if isinstance(p, dict))
        if not isinstance(content, str) or not content.strip():
            raise VLMError("vlm grounding: the model's answer is empty")
        m = re.search(r"\{.*\}", content, re.S)
        if not m:
            if re.search(r"\b(refuse|cannot|can't|unable)\b", content, re.I):
                raise VLMError(f"vlm grounding: the model refused: {content.strip()[:200]}")
            raise VLMError(f"vlm grounding: the answer is not a JSON object: {content.strip()[:200]!r}")
        try:
            ans = json.loads(m.group(0))
        except ValueError:
            raise VLMError(f"vlm grounding: the answer is not valid JSON: {m.group(0)[:200]!r}") from None
        missing = [k for k in ("task", "tool", "work_part", "grasp_part") if k not in ans]
        if missing:
            raise VLMError(f"vlm grounding: the answer lacks {', '.join(missing)}: {m.group(0)[:200]}")
        return ans

    def ground(self, instruction: str, scene: Any) -> Grounding:
        try:
            ans = self._answer(self._post(self.request_body(instruction, scene)))
            tools = scene_tools(scene)
            try:
                number = int(ans["tool"])
            except (TypeError, ValueError):
                raise VLMError(f"vlm grounding: 'tool' must be a tool number, got {ans['tool']!r}") from None
            if not 1 <= number <= len(tools):
                raise VLMError(f"vlm grounding: tool {number} is not on the table (tools 1-{len(tools)})")
            tool = tools[number - 1]
            g = Grounding(instruction=instruction, task=str(ans["task"]), target="", tool_index=number - 1,
                          tool_name=tool.name, work_part=_part_name(ans["work_part"], number, tool),
                          grasp_part=_part_name(ans["grasp_part"], number, tool), grounder="vlm")
            try:
                return validate(g, scene)
            except GroundingError as exc:
                raise VLMError(f"vlm grounding: the model's answer does not fit the table: {exc}") from None
        except VLMError as exc:
            if self.fallback != "rule":
                raise
            g = RuleGrounder().ground(instruction, scene)
            return dataclasses.replace(g, grounder="rule (vlm fallback)", notes=(f"{exc}; used the rule grounder",) + g.notes)
