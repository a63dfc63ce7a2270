"""The API as goniod describes it: proto/openrpc.json, shipped inside the package.

Every method of the client, every exception class and every notification name is made
from this one document when the package is imported, so nothing of the API is written
twice; `rpc.discover` serves the same document from a running goniod.
"""
from __future__ import annotations

import functools
import importlib.resources
import json
from dataclasses import dataclass, field


@functools.cache
def document() -> dict:
    """The OpenRPC document this package was built with."""
    text = importlib.resources.files(__package__).joinpath("openrpc.json").read_text("utf-8")
    return json.loads(text)


@dataclass(frozen=True)
class Param:
    name: str
    required: bool
    schema: dict
    description: str

    def type_text(self) -> str:
        """The schema's type in a few words ("integer ≥ 1", "string | array of string")."""
        return _type_text(self.schema)


@dataclass(frozen=True)
class Method:
    name: str  # "scan.submit"
    summary: str
    description: str
    role: str  # "none", "viewer", "technician", "admin"
    params: tuple[Param, ...] = field(default=())
    result: str = "result"

    @property
    def area(self) -> str:
        """"scan" for scan.submit; "" for the methods without an area (subscribe)."""
        return self.name.rpartition(".")[0]

    @property
    def verb(self) -> str:
        return self.name.rpartition(".")[2]

    @property
    def read_only(self) -> bool:
        """Whether calling it again changes nothing: every method a viewer may call reads."""
        return self.role in ("none", "viewer")

    def docstring(self) -> str:
        lines = [self.summary.strip(), ""]
        if self.description:
            lines += [self.description.strip(), ""]
        if self.params:
            lines.append("Parameters (keywords, JSON-RPC by name):")
            for p in self.params:
                mark = "required" if p.required else _default_text(p.schema)
                lines.append(f"  {p.name} ({p.type_text()}; {mark}): {p.description}")
            lines.append("")
        lines.append(f"Returns the {self.result} (JSON as Python values). JSON-RPC method "
                     f"'{self.name}', role {self.role}.")
        return "\n".join(lines)


@functools.cache
def methods() -> dict[str, Method]:
    """Every method of the document by name, in its order."""
    out = {}
    for m in document()["methods"]:
        params = tuple(Param(p["name"], bool(p.get("required")), p.get("schema", {}),
                             p.get("description", "")) for p in m.get("params", []))
        out[m["name"]] = Method(m["name"], m.get("summary", ""), m.get("description", ""),
                                m.get("x-role", "viewer"), params,
                                m.get("result", {}).get("name", "result"))
    return out


def error_codes() -> list[dict]:
    """x-error-codes: [{code, name, meaning}] — the JSON-RPC codes goniod answers with."""
    return document()["x-error-codes"]


def notifications() -> dict[str, str]:
    """Notification method -> subscription topic ("scan.progress" -> "progress")."""
    return {n["method"]: n["topic"] for n in document()["x-notifications"]}


def _type_text(s: dict) -> str:
    if "$ref" in s:
        return s["$ref"].rpartition("/")[2]
    if "oneOf" in s:
        return " | ".join(_type_text(x) for x in s["oneOf"])
    if "enum" in s:
        return "one of " + ", ".join(json.dumps(v) for v in s["enum"])
    t = s.get("type", "any")
    if isinstance(t, list):
        return " | ".join(t)
    if t == "array":
        return "array of " + _type_text(s.get("items", {}))
    bounds = []
    if "minimum" in s:
        bounds.append(f"≥ {s['minimum']}")
    if "maximum" in s:
        bounds.append(f"≤ {s['maximum']}")
    return t + (" " + ", ".join(bounds) if bounds else "")


def _default_text(s: dict) -> str:
    return f"default {json.dumps(s['default'])}" if "default" in s else "optional"
