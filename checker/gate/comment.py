"""The gate's pull-request comment (`reconf gate --report markdown=FILE`).

The verdict, the findings, the plan's steps, and a Mermaid picture of what the change
touches: the changed components (created, removed or replaced, or whose attachments change)
and their direct neighbours, the components on the same topics. Not the whole architecture:
its Mermaid text passes Mermaid's limit of 50,000 characters at a few hundred components, and
Mermaid then draws nothing but an error. A picture still over the limit is left out, and the
comment says so; the whole comment stays under GitHub's limit of 65,536 characters.

The first line is a marker naming the head (`<!-- reconf-gate: robot.arch -->`), so a
workflow finds the comment it wrote before and updates it instead of adding one per push.
"""
from __future__ import annotations

import re
from typing import Any, Optional

from checker.reports.pictures import plan_picture
from codegen.graph import Picture, to_mermaid
from reconf_dsl.diagnostics import Diagnostic
from reconf_dsl.words import plural

MERMAID_LIMIT = 50_000          # Mermaid's default maxTextSize: over it, nothing is drawn
COMMENT_LIMIT = 65_536          # GitHub's limit on the body of a comment
_SPECIAL = re.compile(r"([\\`*_\[\]<>|#~])")


def marker(head: str) -> str:
    """The hidden first line of the comment, by which a workflow finds it again."""
    return f"<!-- reconf-gate: {head.replace('--', '- -')} -->"


def escape(text: str) -> str:
    return _SPECIAL.sub(r"\\\1", text)


def neighbourhood(pic: Picture) -> Picture:
    """The part of a plan picture that changes: components created or removed, topics whose
    attachments change, and their direct neighbours (a changed component's topics and the
    components on them; a changed topic's components). Environment guarantees are left out."""
    shape = {n.id: n.shape for n in pic.nodes}
    changed = {n.id for n in pic.nodes if n.status in ("created", "removed") and n.shape != "note"}
    for e in pic.edges:
        if e.status in ("created", "removed"):
            changed |= {e.source, e.target}
    adjacent: dict[str, set[str]] = {}
    for e in pic.edges:
        adjacent.setdefault(e.source, set()).add(e.target)
        adjacent.setdefault(e.target, set()).add(e.source)
    keep = set(changed)
    for node in changed:
        if shape.get(node) == "ellipse":
            for topic in adjacent.get(node, ()):
                keep.add(topic)
                keep |= adjacent.get(topic, set())
        else:
            keep |= adjacent.get(node, set())
    return Picture(pic.title, [n for n in pic.nodes if n.id in keep],
                   [e for e in pic.edges if e.source in keep and e.target in keep])


def _finding(d: Diagnostic) -> str:
    mark = "❌" if d.is_error else "⚠️"
    where = f" `{d.span}`" if not d.span.file.startswith("<") else ""
    lines = [f"- {mark} **{d.code}**{where}: {escape(d.message)}"]
    lines += [f"  - {escape(n)}" for n in d.notes[:5]]
    if len(d.notes) > 5:
        lines.append(f"  - … {len(d.notes) - 5} more notes")
    return "\n".join(lines) + "\n"


def _findings(diagnostics: list[Diagnostic], budget: int) -> str:
    out: list[str] = []
    used = 0
    for i, d in enumerate(diagnostics):
        item = _finding(d)
        if used + len(item) > budget:
            out.append(f"- … and {len(diagnostics) - i} more findings: see the check run (SARIF) or "
                       "`--output-format json`\n")
            break
        out.append(item)
        used += len(item)
    return "".join(out)


def _picture(plan: Any, budget: int) -> str:
    whole = plan_picture(plan)
    part = neighbourhood(whole)
    def count(pic: Picture) -> int:       # a replaced component and its replacement are one
        return len({plan.renames.get(n.id.split(":", 1)[1], n.id.split(":", 1)[1]) for n in pic.nodes
                    if n.shape == "ellipse"})

    components, shown = count(whole), count(part)
    part.title = f"{plan.system.name}: what the change touches"
    drawn = {n.id for n in part.nodes}
    outside = sorted(n.id.split(":", 1)[1] for n in whole.nodes
                     if n.status == "degraded" and n.shape == "ellipse" and n.id not in drawn)
    head = (f"**What changes**: the changed components and their direct neighbours ({shown} of {components} "
            "components; green created, red removed, orange degraded at some step).\n\n")
    more = ""
    if outside:
        names = ", ".join(f"`{n}`" for n in outside[:30]) + (f" and {len(outside) - 30} more" if len(outside) > 30
                                                            else "")
        more = f"\nAlso degraded at some step, not drawn: {names}.\n"
    text = to_mermaid(part)
    if len(text) > MERMAID_LIMIT:
        return head + (f"> The picture is {len(text):,} characters of Mermaid, over Mermaid's limit of "
                       f"{MERMAID_LIMIT:,}: it is left out. Draw it with `reconf graph-plan OLD NEW --format svg`.\n"
                       ) + more
    block = "```mermaid\n" + text + "```\n"
    if len(head) + len(block) + len(more) > budget:
        return head + (f"> The picture ({len(text):,} characters) would take this comment over GitHub's limit of "
                       f"{COMMENT_LIMIT:,}: it is left out. Draw it with `reconf graph-plan OLD NEW --format svg`.\n"
                       ) + more
    return head + block + more


def comment(*, verdict: str, base: str, head: str, diagnostics: list[Diagnostic], summary: str,
            plan: Any = None, notes: tuple[str, ...] = ()) -> str:
    """The markdown comment of a gate that ran: `verdict` is pass, fail or error (bad input)."""
    title = {"pass": "✅ architecture gate passed", "fail": "❌ architecture gate failed",
             "error": "⚠️ architecture gate could not judge the change"}[verdict]
    parts = [marker(head) + "\n", f"### {title}\n\n", f"`{base}` → `{head}`: {escape(summary)}\n\n"]
    parts += [f"> {escape(n)}\n\n" for n in notes]
    if diagnostics:
        parts.append(f"**Findings** ({len(diagnostics)})\n\n")
        parts.append(_findings(diagnostics, COMMENT_LIMIT // 3))
        parts.append("\n")
    if plan is not None:
        if not plan.steps:
            parts.append("**Plan**: nothing to do: the head is the deployed configuration.\n")
        else:
            steps = plan.describe()
            listed, size = [], 0
            for line in steps[:300]:                # at most 300 steps and a third of the comment
                size += len(line) + 1
                if size > COMMENT_LIMIT // 3:
                    break
                listed.append(line)
            said = escape(plan.summary())
            said = said if len(said) <= 2_000 else said[:2_000] + "…"   # it names every functionality left degraded
            parts.append(f"**Plan**: {said}\n\n<details><summary>{plural(len(steps), 'step')}</summary>\n\n"
                         "```text\n" + "\n".join(listed) + "\n"
                         + (f"… {plural(len(steps) - len(listed), 'more step')}\n" if len(steps) > len(listed)
                            else "")
                         + "```\n\n</details>\n\n")
            used = sum(len(p) for p in parts)
            parts.append(_picture(plan, COMMENT_LIMIT - used - 1_000))
    text = "".join(parts)
    if len(text) > COMMENT_LIMIT:               # many notes or findings: cut, and say so, rather than be refused
        cut = "\n\n… (cut at GitHub's limit of 65,536 characters; the JSON report has everything)\n"
        text = text[:COMMENT_LIMIT - len(cut)] + cut
    return text


def failure_comment(base: str, head: str, diagnostics: list[Diagnostic], summary: Optional[str] = None) -> str:
    n = sum(1 for d in diagnostics if d.is_error)
    return comment(verdict="error", base=base, head=head, diagnostics=diagnostics,
                   summary=summary or f"{plural(n, 'error')}: nothing was judged")
