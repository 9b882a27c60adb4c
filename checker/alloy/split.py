"""A generated module in two parts, for the analyzer's front end.

Instance and plan modules declare every atom as a `one sig` and their data as `fun`
constants over those atoms. The analyzer's front end resolves each name against every
signature of the module, and types each union of atom products as a union of as many
product types: both grow with the square of the atoms (a 700-atom module took 0.2 s to
parse, more than its solving). `split_module` separates such a module into

- a *skeleton*: the module with its atom declarations and the bodies that mention atoms
  left out (each body replaced by an empty value of its declared type), which the front
  end parses as usual;
- the *atoms*, each with the sig it extends, which the bridge declares through the
  analyzer's API (the same `one sig`s);
- the *bodies*, which the bridge parses one by one against the skeleton with each atom
  bound by name, as a constant of its parent sig's type, and sets on their fun or pred.

The judged module is the same (the same sigs, the same bodies, the same commands); only
the front end's work is linear. A module whose atoms are referenced where a body cannot
be replaced (a fun or pred with parameters) keeps those atoms declared in the text.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_ONE_SIG = re.compile(r"^one sig ([\w, ]+?) extends (\w+) \{\}$", re.M)
# a top-level fun or pred without parameters, as the templates write them
_BLOCK = re.compile(r"^(fun|pred) (\w+)(?:: ([^{\n]+?))? \{\n(.*?)\n\}$", re.M | re.S)
_BLANK = re.compile(r"\n\s*\n")
_COMMENT = re.compile(r"/\*.*?\*/|--[^\n]*|//[^\n]*", re.S)

# below this many atoms the front end is fast enough as it is
MIN_ATOMS = 150


@dataclass(frozen=True)
class Split:
    skeleton: str
    atoms: list[tuple[str, str]]  # (atom, the sig it extends), in declaration order
    bodies: dict[str, str]  # fun or pred name -> its body


def split_module(text: str, min_atoms: int | None = None) -> Split | None:
    """`text` in two parts (see above), or None when it has fewer than `min_atoms` atoms
    (by default `MIN_ATOMS`)."""
    min_atoms = MIN_ATOMS if min_atoms is None else min_atoms
    declared = [(a.strip(), m.group(2)) for m in _ONE_SIG.finditer(text) for a in m.group(1).split(",")]
    if len(declared) < min_atoms:
        return None
    names = {a for a, _ in declared}
    bodies: dict[str, str] = {}

    def hollow(m: re.Match[str]) -> str:
        kind, name, typ, body = m.group(1), m.group(2), m.group(3), m.group(4)
        if not names.intersection(IDENTIFIER.findall(body)):
            return m.group(0)
        bodies[name] = body
        if kind == "pred":
            return f"pred {name} {{\n  some none\n}}"
        return f"fun {name}: {typ} {{\n  {_empty(typ)}\n}}"

    skeleton = _BLOCK.sub(hollow, text)
    # atoms the skeleton still names stay declared in it
    kept = names.intersection(IDENTIFIER.findall(_COMMENT.sub("", _ONE_SIG.sub("", skeleton))))
    atoms = [(a, parent) for a, parent in declared if a not in kept]

    def declare(m: re.Match[str]) -> str:
        stay = [a.strip() for a in m.group(1).split(",") if a.strip() in kept]
        return f"one sig {', '.join(stay)} extends {m.group(2)} {{}}" if stay else ""

    return Split(_ONE_SIG.sub(declare, skeleton), atoms, bodies)


def skeleton_key(skeleton: str) -> str:
    """What identifies a skeleton for the analyzer: its text without comments and blank
    lines (a plan module's header comment names its states; atom declarations leave blank
    lines)."""
    return _BLANK.sub("\n", _COMMENT.sub("", skeleton))


def _empty(typ: str) -> str:
    """An empty value of a declared fun type such as `set X` or `A -> B`."""
    columns = [c.strip() for c in typ.replace("set ", "").replace("lone ", "").split("->")]
    if len(columns) == 1:
        return "none"
    product = " -> ".join(columns)
    return f"({product} - {product})"
