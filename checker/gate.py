"""`reconf gate --base OLD --head NEW`: a CI gate for architecture changes.

It passes when NEW is safe and a verified migration plan from OLD to NEW exists within the
policy (`checker.policy`): disruption at most max-disruption, no never-degrade functionality
degraded at any step, no fault covered in OLD left uncovered by NEW's FTMs (keep-ftm).
OLD and NEW are paths, or `git:REF:PATH` read from the repository of the working directory
without checking it out (PATH from the repository root, or from here when it starts `./`).
"""
from __future__ import annotations

import contextlib
import io
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
from dataclasses import dataclass, field, replace
from typing import Any, Iterator, Optional

import click

from reconf_dsl.diagnostics import Diagnostic, DiagnosticError, Related, error
from reconf_dsl.ir import System
from reconf_dsl.loader import Sources, display_path, load
from reconf_dsl.span import Span

from . import formats, report
from .cli import EXIT_OK, EXIT_UNSAFE, emit_report, engine_option, format_option, guarded, plural, solver_option
from .config import Configuration
from .engines import EngineUnavailable
from .policy import Policy, check_names, covered, coverage, ftm_names, load_policy
from .progress import status
from .report import ReportFormat

GIT_PREFIX = "git:"


# ---------------------------------------------------------------- reading revisions

@dataclass
class Revisions:
    """Trees of git revisions extracted to temporary directories, and how to name their files."""

    roots: dict[str, str] = field(default_factory=dict)        # ref → extracted tree
    renames: dict[str, str] = field(default_factory=dict)      # shown prefix of a tree → the work tree's root

    def rename(self, file: str) -> str:
        """A file of an extracted revision as the same file of the work tree is shown."""
        for tmp, top in self.renames.items():
            if file.startswith(tmp):
                return display_path(os.path.join(top, file[len(tmp):]))
        return file

    def span(self, s: Span) -> Span:
        new = self.rename(s.file)
        return s if new == s.file else replace(s, file=new)

    def diagnostic(self, d: Diagnostic) -> Diagnostic:
        return replace(d, span=self.span(d.span),
                       related=tuple(replace(r, span=self.span(r.span)) for r in d.related))


def git(args: list[str], cwd: str, what: str) -> bytes:
    try:
        done = subprocess.run(["git", *args], cwd=cwd, capture_output=True, check=False)
    except FileNotFoundError:
        raise DiagnosticError([error("RC506", f"cannot read {what}: git is not installed",
                                     Span.unknown("<git>"))]) from None
    if done.returncode != 0:
        msg = done.stderr.decode("utf-8", "replace").strip().splitlines()
        raise DiagnosticError([error("RC506", f"cannot read {what}: {msg[-1] if msg else 'git failed'}",
                                     Span.unknown("<git>"))])
    return done.stdout


def split_ref(spec: str) -> tuple[str, str]:
    body = spec[len(GIT_PREFIX):]
    ref, sep, path = body.rpartition(":")
    if not sep or not ref or not path:
        raise DiagnosticError([error("RC506", f"'{spec}' is not git:REF:PATH", Span.unknown("<command line>"),
                                     notes=("for example git:origin/main:examples/robot.arch",))])
    return ref, path


@contextlib.contextmanager
def revisions() -> Iterator[Revisions]:
    revs = Revisions()
    try:
        yield revs
    finally:
        for root in revs.roots.values():
            shutil.rmtree(root, ignore_errors=True)


def resolve(spec: str, revs: Revisions) -> str:
    """A path to load for a path or a `git:REF:PATH`."""
    if not spec.startswith(GIT_PREFIX):
        return spec
    ref, path = split_ref(spec)
    cwd = os.getcwd()
    top = git(["rev-parse", "--show-toplevel"], cwd, spec).decode().strip()
    if path.startswith("./") or path.startswith("../"):
        prefix = git(["rev-parse", "--show-prefix"], cwd, spec).decode().strip()
        path = os.path.normpath(os.path.join(prefix, path))
    git(["cat-file", "-e", f"{ref}:{path}"], cwd, spec)
    if ref not in revs.roots:
        tree = git(["archive", "--format=tar", ref], top, spec)
        root = tempfile.mkdtemp(prefix="reconf-rev-")
        with tarfile.open(fileobj=io.BytesIO(tree)) as tar:
            tar.extractall(root, filter="data")
        revs.roots[ref] = root
        revs.renames[display_path(root) + os.sep] = top
    return os.path.join(revs.roots[ref], path)


# ---------------------------------------------------------------- judging a change

@dataclass
class Outcome:
    diagnostics: list[Diagnostic] = field(default_factory=list)
    cases: list[formats.CheckCase] = field(default_factory=list)
    plan: Any = None
    plan_doc: Optional[dict[str, Any]] = None
    safe: Optional[bool] = None
    engines: dict[str, Any] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return not any(d.is_error for d in self.diagnostics)

    def fail(self, suite: str, name: str, d: Diagnostic) -> None:
        self.diagnostics.append(d)
        self.cases.append(formats.CheckCase(suite, name, d.message, "\n".join(d.notes), d.span))

    def ok(self, suite: str, name: str, span: Optional[Span] = None) -> None:
        self.cases.append(formats.CheckCase(suite, name, None, "", span))


def ftm_findings(old: System, new: System, policy: Policy, out: Outcome) -> None:
    """keep-ftm: a fault covered in OLD must stay covered by the same component's FTM in NEW."""
    news = {c.name: c for c in new.components}
    for c in old.components:
        before = covered(c)
        if not before or not policy.protects_ftm(c.name, ftm_names(c.ftm.expr if c.ftm else None)):
            continue
        n = news.get(c.name)
        if n is None:
            continue
        lost = sorted(before - coverage(n.ftm.expr if n.ftm else None))
        name = f"the FTM of {c.name} still covers {', '.join(sorted(before))}"
        if not lost:
            out.ok("gate.policy", name, n.span)
            continue
        was = str(c.ftm.expr) if c.ftm else "none"
        now = str(n.ftm.expr) if n.ftm else "no FTM"
        out.fail("gate.policy", name, error(
            "RC504", f"{c.name}: {', '.join(lost)} fault{'s' if len(lost) > 1 else ''} no longer covered "
            f"({was} → {now}); keep-ftm in {policy.where} forbids weakening it",
            n.ftm.span if n.ftm else n.span,
            related=(Related(c.ftm.span if c.ftm else c.span, f"covered by {was} in the base"),
                     Related(policy.span("keep-ftm"), "keep-ftm")),
            notes=("coverage: PBR, LFR → crash; TR → transient; AD → crash, transient; SEC → intrusion",)))


def degraded_steps(plan: Any) -> dict[tuple[str, str], list[int]]:
    """(component as NEW names it, functionality) → the steps after which it is degraded."""
    out: dict[tuple[str, str], list[int]] = {}
    for i, state in enumerate(plan.states[1:], 1):
        for c, f in sorted(state.degraded):
            if c in state.components:
                out.setdefault((plan.renames.get(c, c), f), []).append(i)
    return out


def func_span(systems: list[System], component: str, functionality: str) -> Optional[Span]:
    for s in systems:
        c = s.component(component)
        if c is not None:
            for f in c.functionalities:
                if f.name == functionality:
                    return f.span
    return None


def plan_findings(old: System, new: System, policy: Policy, use_alloy: bool, solver: str, out: Outcome) -> None:
    from .plan_cli import plan_document
    from .planning import NoSafePlan, plan_migrate

    with status(f"planning the migration {old.name} → {new.name}…"):
        try:
            p = plan_migrate(old, new, policy.strategy)
        except NoSafePlan as e:
            out.fail("gate.policy", "a verified migration plan exists", error(
                "RC501", f"no safe migration plan from the base to {new.name} ({policy.strategy} strategy)",
                new.span, notes=tuple(e.reasons)))
            return
        evidence: dict[str, Any] = {"python": {"engine": "python", "states": len(p.states), "valid": True}}
        if use_alloy:
            evidence["alloy"] = alloy_evidence(p, solver)
    if use_alloy and not evidence["alloy"].get("valid", False):
        said = "could not verify" if evidence["alloy"].get("verdict") == "not run" else "refuted"
        out.fail("gate.policy", "a verified migration plan exists", error(
            "RC501", f"Alloy {said} the migration plan: {evidence['alloy'].get('reason', 'unknown')}", new.span))
        return
    out.plan = p
    out.plan_doc = plan_document("migrate", old, p, evidence, new)
    out.ok("gate.policy", "a verified migration plan exists", new.span)
    if policy.max_disruption is not None:
        name = f"disruption at most {policy.max_disruption}"
        if p.disruption > policy.max_disruption:
            out.fail("gate.policy", name, error(
                "RC502", f"the migration plan's disruption is {p.disruption}, over max-disruption = "
                f"{policy.max_disruption} of {policy.where}", new.span,
                related=(Related(policy.span("max-disruption"), f"max-disruption = {policy.max_disruption}"),),
                notes=(f"plan: {p.summary()}", "disruption = Σ criticality × steps degraded")))
        else:
            out.ok("gate.policy", name, policy.span("max-disruption"))
    degraded = degraded_steps(p)
    for i, entry in enumerate(policy.never_degrade):
        hits = sorted((k, v) for k, v in degraded.items() if policy.forbids_degrading(*k) == entry)
        name = f"never degrade {entry}"
        if not hits:
            out.ok("gate.policy", name, policy.entry_span("never-degrade", i))
            continue
        for (c, f), steps in hits:
            span = func_span([new, old], c, f) or new.span
            out.fail("gate.policy", f"{name} ({c}.{f})", error(
                "RC503", f"the migration plan degrades {c}.{f} during {plural(len(steps), 'step')} "
                f"({', '.join(map(str, steps))}); never-degrade in {policy.where} forbids it", span,
                related=(Related(policy.entry_span("never-degrade", i), f"never-degrade includes {entry!r}"),),
                notes=(f"plan: {p.summary()}",)))


def alloy_evidence(p: Any, solver: str) -> dict[str, Any]:
    from .alloy import AlloyError, AlloyUnavailable
    from .alloy_plan import alloy_evidence as evidence
    try:
        return evidence(p, solver)
    except AlloyUnavailable as e:
        raise EngineUnavailable(error("RC301", str(e), Span.unknown("<alloy>"),
                                      notes=("or use --engine python",))) from None
    except AlloyError as e:
        raise EngineUnavailable(error("RC302", f"Alloy rejected the generated plan module: {e}",
                                      Span.unknown(e.module or "<alloy>"),
                                      notes=("this is a bug in reconf: please report it",))) from None


def judge_change(old: System, new: System, policy: Policy, engine: str, solver: str) -> Outcome:
    from .engines import judge
    out = Outcome()
    ftm_findings(old, new, policy, out)
    with status(f"checking {new.name}" + (" in the Alloy Analyzer" if engine != "python" else "") + "…"):
        judged = judge(new, Configuration.initial(new), engine, solver)
    out.safe, out.engines = judged.valid, judged.engines
    out.cases[:0] = report.assumption_cases(new.name, judged.python)
    out.diagnostics[:0] = [report.assumption_diagnostic(r) for r in judged.python.unsatisfied]
    if not judged.valid:
        d = error("RC507", f"{new.name} is not safe: no migration to it is planned", new.span,
                  notes=(f"{plural(len(judged.python.unsatisfied), 'assumption')} "
                         f"{'does' if len(judged.python.unsatisfied) == 1 else 'do'} not hold; see above",))
        out.fail("gate.policy", "a verified migration plan exists", d)
        return out
    plan_findings(old, new, policy, engine != "python", solver, out)
    return out


# ---------------------------------------------------------------- the command

@click.command("gate")
@click.option("--base", "base", required=True, metavar="OLD",
              help="the deployed architecture: a path or git:REF:PATH (e.g. git:origin/main:robot.arch)")
@click.option("--head", "head", required=True, metavar="NEW", help="the proposed architecture: a path or git:REF:PATH")
@click.option("--policy", "policy_file", type=click.Path(dir_okay=False),
              help="policy TOML (default: reconf.toml, or [tool.reconf] in pyproject.toml, found from here)")
@format_option
@engine_option
@solver_option
@guarded("gate")
def gate_cmd(base: str, head: str, policy_file: Optional[str], output_format: ReportFormat, engine: str, solver: str,
             sources: Sources) -> None:
    """Pass when NEW is safe and a verified migration plan from OLD to NEW exists within the policy.

    \b
    Policy keys ([tool.reconf] in pyproject.toml, or reconf.toml):
      max-disruption = N        Σ criticality × steps degraded, at most N
      never-degrade = [...]     COMPONENT.FUNCTIONALITY or FUNCTIONALITY never degraded
      keep-ftm = true | [...]   faults covered by these components' (or FTMs') mechanisms stay covered
      strategy = "default"      planning strategy
    Every name must name something in NEW or OLD (RC508).
    Exit codes: 0 pass, 1 fail, 2 bad input.
    """
    policy = load_policy(policy_file, sources=sources)
    with revisions() as revs:
        try:
            old = load([resolve(base, revs)], sources)
            new = load([resolve(head, revs)], sources)
            wrong = check_names(policy, old, new)
            if wrong:
                raise DiagnosticError(wrong)
        except DiagnosticError as e:
            rename_sources(sources, revs)
            raise DiagnosticError([revs.diagnostic(d) for d in e.diagnostics]) from None
        rename_sources(sources, revs)
        out = judge_change(old, new, policy, engine, solver)
        out.diagnostics = [revs.diagnostic(d) for d in out.diagnostics]
        out.cases = [replace(c, span=revs.span(c.span)) if c.span else c for c in out.cases]
    verdict = "pass" if out.passed else "fail"
    n = sum(1 for d in out.diagnostics if d.is_error)
    plan_line = f"; plan: {out.plan.summary()}" if out.plan is not None else ""
    line = f"{base} → {head}" + (f": {new.name} is safe{plan_line}, within {policy.where}" if out.passed else
                                 f": {plural(n, 'reason')}{plan_line}")
    human = f"[bold green]✓ gate passed[/] {line}" if out.passed else f"[bold red]✗ gate failed[/] {line}"
    rep = formats.Report("gate", verdict, out.diagnostics, out.cases, f"gate {verdict}: {line}")
    emit_report(rep, output_format, sources,
                lambda: report.document("gate", verdict, out.diagnostics, base=base, head=head,
                                        policy=policy.to_json(), safe=out.safe, engines=out.engines,
                                        plan=out.plan_doc), human)
    sys.exit(EXIT_OK if out.passed else EXIT_UNSAFE)


def rename_sources(sources: Sources, revs: Revisions) -> None:
    for key in list(sources.texts):
        new = revs.rename(key)
        if new != key:
            sources.texts[new] = sources.texts.pop(key)
