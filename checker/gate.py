"""`reconf gate --base OLD --head NEW`: a CI gate for architecture changes.

It passes when NEW is safe and a verified migration plan from OLD to NEW exists within the
policy (`checker.policy`): disruption at most max-disruption, no never-degrade functionality
degraded at any step, no fault covered in OLD left uncovered by NEW's FTMs (keep-ftm).
When OLD itself is not safe no plan from it exists: the gate fails (RC509) and says how to let
a fix through; with `--allow-unsafe-base` (or `allow-unsafe-base = true`) a safe NEW passes
alone, with a warning (RC510) that it must be deployed by other means.

OLD, NEW and the policy are paths, or `git:REF:PATH` read from the repository of the working
directory without checking it out (PATH from the repository root, or from here when it starts
`./` or `../`): only the named file and the files it includes, transitively, are read from
the revision (`git cat-file --batch`), never the whole tree.
"""
from __future__ import annotations

import contextlib
import os
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field, replace
from typing import IO, Any, Callable, Iterator, Optional

import click

from reconf_dsl import ir
from reconf_dsl.diagnostics import Diagnostic, DiagnosticError, Related, error, warning
from reconf_dsl.ir import System
from reconf_dsl.loader import MAX_FILE_BYTES, Sources, display_path, load
from reconf_dsl.parser import parse_text
from reconf_dsl.span import Span

from . import formats, report
from .command import (EXIT_CHANGES, EXIT_OK, EXIT_UNSAFE, CannotWrite, Failure, emit_report, engine_option,
                  format_option, guarded, plural, solver_option, write_atomically)
from .config import Configuration
from .engines import EngineUnavailable, EnginesDisagree
from .planning.plan import degraded_runs
from .policy import Policy, check_names, covered, coverage, ftm_names, load_policy
from .progress import status
from .report import ReportFormat

GIT_PREFIX = "git:"


# ---------------------------------------------------------------- reading revisions

class _CatFile:
    """One `git cat-file --batch --follow-symlinks` process: objects by name, one at a time."""

    def __init__(self, top: str) -> None:
        self.aborted = False
        try:
            self.proc = subprocess.Popen(["git", "cat-file", "--batch", "--follow-symlinks"], cwd=top,
                                         stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        except FileNotFoundError:
            raise DiagnosticError([error("RC506", "cannot read from git: git is not installed",
                                         Span.unknown("<git>"))]) from None

    def blob(self, name: str, limit: int) -> tuple[str, Optional[bytes], int]:
        """(kind, content, size) of the object `name`: kind "blob" with its content when it is a
        file of at most `limit` bytes, "missing" when there is none, else its kind and no content."""
        stdin, stdout = self.proc.stdin, self.proc.stdout
        assert stdin is not None and stdout is not None
        try:
            stdin.write(name.encode("utf-8") + b"\n")
            stdin.flush()
            header = stdout.readline()
        except (BrokenPipeError, OSError):
            header = b""
        if not header:
            raise DiagnosticError([error("RC506", f"cannot read {name}: git cat-file stopped",
                                         Span.unknown("<git>"))])
        parts = header.split()
        if len(parts) == 3 and parts[2].isdigit() and parts[1] in (b"blob", b"tree", b"commit", b"tag"):
            kind, size = parts[1].decode(), int(parts[2])
            if kind == "blob" and size > limit:
                self.abort()            # not read through: the process is stopped instead
                return "large", None, size
            if kind != "blob":
                self._skip(stdout, size + 1)
                return kind, None, size
            data = self._exactly(stdout, size)
            self._skip(stdout, 1)
            return "blob", data, size
        if len(parts) == 2 and parts[1].isdigit() and parts[0] in (b"symlink", b"dangling", b"loop", b"notdir"):
            self._skip(stdout, int(parts[1]) + 1)
            return parts[0].decode(), None, 0
        return "missing", None, 0

    @staticmethod
    def _exactly(stream: IO[bytes], n: int) -> bytes:
        chunks, left = [], n
        while left:
            chunk = stream.read(min(left, 1 << 20))
            if not chunk:
                raise DiagnosticError([error("RC506", "git cat-file stopped in the middle of a file",
                                             Span.unknown("<git>"))])
            chunks.append(chunk)
            left -= len(chunk)
        return b"".join(chunks)

    @staticmethod
    def _skip(stream: IO[bytes], n: int) -> None:
        while n > 0:
            chunk = stream.read(min(n, 1 << 20))
            if not chunk:
                return
            n -= len(chunk)

    def abort(self) -> None:
        self.proc.kill()
        self.proc.wait()
        for stream in (self.proc.stdin, self.proc.stdout):
            if stream:
                with contextlib.suppress(OSError):
                    stream.close()
        self.aborted = True

    def close(self) -> None:
        if self.aborted:
            return
        if self.proc.stdin:
            with contextlib.suppress(OSError):
                self.proc.stdin.close()
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        if self.proc.stdout:
            self.proc.stdout.close()


@dataclass
class Revisions:
    """Files of git revisions, each written to a temporary directory of its revision (at the
    same path as in the repository, so includes resolve as in a checkout), and how to name them.
    Only the files asked for, and what they include, are read: never the whole tree."""

    roots: dict[str, str] = field(default_factory=dict)        # commit → its temporary directory
    renames: dict[str, str] = field(default_factory=dict)      # shown prefix of a directory → the work tree's root
    top: Optional[str] = None                                  # the repository's work tree
    _commits: dict[str, str] = field(default_factory=dict)     # ref → commit
    _cat: Optional[_CatFile] = None

    def rename(self, file: str) -> str:
        """A file of a revision as the same file of the work tree is shown."""
        for tmp, top in self.renames.items():
            if file.startswith(tmp):
                return display_path(os.path.join(top, file[len(tmp):]))
        return file

    def rename_text(self, text: str) -> str:
        """Paths of a revision's files in a message, as the work tree's."""
        for tmp in self.renames:
            if tmp in text:
                text = re.sub(re.escape(tmp) + r"[^\s:,;)'\"]*", lambda m: self.rename(m.group(0)), text)
        return text

    def span(self, s: Span) -> Span:
        new = self.rename(s.file)
        return s if new == s.file else replace(s, file=new)

    def diagnostic(self, d: Diagnostic) -> Diagnostic:
        return replace(d, span=self.span(d.span), message=self.rename_text(d.message),
                       notes=tuple(self.rename_text(n) for n in d.notes),
                       related=tuple(replace(r, span=self.span(r.span), message=self.rename_text(r.message))
                                     for r in d.related))

    def close(self) -> None:
        if self._cat is not None:
            self._cat.close()
            self._cat = None
        for root in self.roots.values():
            shutil.rmtree(root, ignore_errors=True)

    # -- reading

    def toplevel(self, spec: str) -> str:
        if self.top is None:
            self.top = git(["rev-parse", "--show-toplevel"], os.getcwd(), spec).decode().strip()
        return self.top

    def commit(self, ref: str, spec: str) -> str:
        if ref not in self._commits:
            top = self.toplevel(spec)
            try:
                done = subprocess.run(["git", "rev-parse", "--verify", "--quiet", "--end-of-options",
                                       f"{ref}^{{commit}}"], cwd=top, capture_output=True, check=False)
            except FileNotFoundError:
                raise DiagnosticError([error("RC506", f"cannot read {spec}: git is not installed",
                                             Span.unknown("<git>"))]) from None
            if done.returncode != 0:
                raise DiagnosticError([error("RC506", f"cannot read {spec}: there is no revision '{ref}' in the "
                                             f"repository at {display_path(top)}", Span.unknown("<command line>"),
                                             notes=("a branch, tag or commit; in CI, fetch it first (actions/checkout "
                                                    "with fetch-depth: 0)",))])
            self._commits[ref] = done.stdout.decode().strip()
        return self._commits[ref]

    def fetch(self, ref: str, path: str, spec: str, includes: bool) -> str:
        """Write PATH of REF, and with `includes` every file it includes transitively, to REF's
        directory; the path to load. A missing include is left to the loader to report."""
        top = self.toplevel(spec)
        commit = self.commit(ref, spec)
        if commit not in self.roots:
            root = tempfile.mkdtemp(prefix="reconf-rev-")
            self.roots[commit] = root
            self.renames[display_path(root) + os.sep] = top
        root = self.roots[commit]
        if self._cat is None:
            self._cat = _CatFile(top)
        queue: list[tuple[str, Optional[Span]]] = [(path, None)]
        while queue:
            rel, at = queue.pop(0)
            dest = os.path.join(root, rel)
            if os.path.exists(dest):
                continue
            if "\n" in rel:
                raise DiagnosticError([error("RC506", f"cannot read {rel!r} from git: a path with a line break",
                                             at or Span.unknown("<command line>"))])
            kind, data, size = self._cat.blob(f"{commit}:{rel}", MAX_FILE_BYTES)
            if kind == "large":
                self._cat = None
                raise DiagnosticError([error("RC010", f"{rel} at {ref} is {size} bytes; the limit is {MAX_FILE_BYTES}",
                                             at or Span.unknown("<command line>"))])
            if data is None:
                if at is not None:
                    continue        # the loader reports the include it cannot find, where it is written
                what = "a directory" if kind == "tree" else "not in the repository" if kind in (
                    "symlink", "dangling", "loop", "notdir") else "missing"
                raise DiagnosticError([error("RC506", f"cannot read {spec}: {rel} is {what} at {ref}"
                                             if kind != "missing" else
                                             f"cannot read {spec}: there is no {rel} at {ref}",
                                             Span.unknown("<command line>"))])
            os.makedirs(os.path.dirname(dest), exist_ok=True)
            with open(dest, "wb") as f:
                f.write(data)
            if includes:
                queue.extend(self._includes(root, rel, data, ref))
        return os.path.join(root, path)

    @staticmethod
    def _includes(root: str, rel: str, data: bytes, ref: str) -> list[tuple[str, Optional[Span]]]:
        """What the file includes, as paths in the repository; a file that does not parse
        includes nothing here (the loader reports why)."""
        try:
            doc = parse_text(data.decode("utf-8").removeprefix("\ufeff"), display_path(os.path.join(root, rel)))
        except (DiagnosticError, UnicodeDecodeError):
            return []
        out: list[tuple[str, Optional[Span]]] = []
        for item in doc.items:
            if not isinstance(item, ir.Include) or os.path.isabs(item.path):
                continue            # an absolute path is read from the disk, as in a checkout
            target = os.path.normpath(os.path.join(os.path.dirname(rel), item.path))
            if target == ".." or target.startswith(".." + os.sep):
                raise DiagnosticError([error("RC506", f"{rel} includes {item.path}, which is outside the "
                                             f"repository: it cannot be read from {ref}", item.span)])
            out.append((target, item.span))
        return out


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
        revs.close()


def resolve(spec: str, revs: Revisions, includes: bool = True) -> str:
    """A path to load for a path or a `git:REF:PATH` (with `includes`, what it includes is read too)."""
    if not spec.startswith(GIT_PREFIX):
        return spec
    ref, path = split_ref(spec)
    revs.toplevel(spec)
    if path.startswith("./") or path.startswith("../"):
        prefix = git(["rev-parse", "--show-prefix"], os.getcwd(), spec).decode().strip()
        path = os.path.join(prefix, path)
    path = os.path.normpath(path)
    if path == ".." or path.startswith(".." + os.sep) or os.path.isabs(path):
        raise DiagnosticError([error("RC506", f"cannot read {spec}: {path} is outside the repository",
                                     Span.unknown("<command line>"))])
    return revs.fetch(ref, path, spec, includes)


# ---------------------------------------------------------------- judging a change

@dataclass
class Outcome:
    diagnostics: list[Diagnostic] = field(default_factory=list)
    cases: list[formats.CheckCase] = field(default_factory=list)
    plan: Any = None
    plan_doc: Optional[dict[str, Any]] = None
    safe: Optional[bool] = None
    base_safe: Optional[bool] = None
    engines: dict[str, Any] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return not any(d.is_error for d in self.diagnostics)

    @property
    def nothing_to_do(self) -> bool:
        """A pass whose plan has no step: NEW is what is deployed."""
        return self.passed and self.plan is not None and not self.plan.steps

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
            "RC504", f"{c.name}: {', '.join(lost)} {report.agree(len(lost), 'fault', 'faults')} no longer covered "
            f"({was} → {now}); keep-ftm in {policy.where} forbids weakening it",
            n.ftm.span if n.ftm else n.span,
            related=(Related(c.ftm.span if c.ftm else c.span, f"covered by {was} in the base"),
                     Related(policy.span("keep-ftm"), "keep-ftm")),
            notes=("coverage: PBR, LFR → crash; TR → transient; AD → crash, transient; SEC → intrusion",)))


def degraded_steps(plan: Any) -> dict[tuple[str, str], list[int]]:
    """(component as NEW names it, functionality) → the steps after which it is degraded."""
    return {(plan.renames.get(c, c), f): [i for r in runs for i in r]
            for (c, f), runs in sorted(degraded_runs(plan).items())}


def func_span(systems: list[System], component: str, functionality: str) -> Optional[Span]:
    for s in systems:
        c = s.component(component)
        if c is not None:
            for f in c.functionalities:
                if f.name == functionality:
                    return f.span
    return None


def plan_findings(old: System, new: System, policy: Policy, use_alloy: bool, solver: str, out: Outcome) -> None:
    from .alloy_plan import PlanVerdicts
    from .plan_cli import plan_document
    from .planning import Fallback, NoSafePlan, plan_migrate

    verdicts = PlanVerdicts(lambda p: alloy_evidence(p, solver)) if use_alloy else None
    with status(f"planning the migration {old.name} → {new.name}…"):
        try:
            fallback = Fallback(accept=verdicts.refused if verdicts else None, alloy=use_alloy)
            p = plan_migrate(old, new, policy.strategy, fallback=fallback)
        except NoSafePlan as e:
            out.fail("gate.policy", "a verified migration plan exists", error(
                "RC501", f"no safe migration plan from the base to {new.name} ({policy.strategy} strategy and "
                "those after it)", new.span, notes=tuple(e.reasons)))
            return
        evidence: dict[str, Any] = {"python": {"engine": "python", "states": len(p.states), "valid": True}}
        if verdicts is not None:
            evidence["alloy"] = verdicts.evidence(p)
    if use_alloy and evidence["alloy"].get("verdict") == "not run":     # not answered: exit 2, as `plan` does
        raise DiagnosticError([error("RC303", f"Alloy could not verify the migration plan: "
                                              f"{evidence['alloy'].get('reason', 'unknown')}", new.span,
                                     notes=("`--engine python` relies on the Python engine's step-by-step "
                                            "verification alone",))])
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


UNSAFE_BASE_CASE = "the base is safe, so a migration from it can be planned"


def unsafe_base_findings(old: System, new: System, failing: list[tuple[str, str, Any]], allowed: Optional[str],
                         out: Outcome) -> None:
    """OLD is not safe, NEW is: no plan from the deployed configuration exists. `allowed` says
    what lets a fix through (the flag or the policy key), None when nothing does."""
    shown = [f"{c}.{f} assumes {a}, which does not hold" for c, f, a in failing]
    reasons = shown[:10] + ([f"… and {len(shown) - 10} more"] if len(shown) > 10 else [])
    related = tuple(Related(s, f"in the base, {c}.{f} assumes {a}, which does not hold")
                    for c, f, a in failing[:10] if (s := func_span([old], c, f)) is not None)
    deploy = ("deployed by other means (a restart, a maintenance window), as no safe step-by-step plan from "
              "the deployed configuration exists")
    if allowed is None:
        out.fail("gate.policy", UNSAFE_BASE_CASE, error(
            "RC509", f"the base {old.name} is not safe ({plural(len(failing), 'assumption')} "
            f"{report.agree(len(failing), 'does', 'do')} not hold), so no safe migration from the deployed "
            f"configuration exists; {new.name} is safe", old.span, related=related,
            notes=(*reasons, "if this change fixes the base, let it through with --allow-unsafe-base or "
                   "allow-unsafe-base = true in the policy: the gate then judges the head alone, and the change "
                   "must be " + deploy)))
        return
    out.diagnostics.append(warning(
        "RC510", f"the base {old.name} is not safe ({plural(len(failing), 'assumption')} "
        f"{report.agree(len(failing), 'does', 'do')} not hold): {new.name} was judged alone and is safe; "
        f"{allowed} lets it through, but no safe plan from the deployed configuration exists: deploy it by "
        "other means", old.span, related=related,
        notes=(*reasons, "the change must be " + deploy,
               "max-disruption and never-degrade were not checked: they judge a plan")))
    out.ok("gate.policy", f"{new.name} is safe alone (the base is not; {allowed})", new.span)


def judge_change(old: System, new: System, policy: Policy, engine: str, solver: str,
                 allow_unsafe_base: bool = False) -> Outcome:
    from .actions import failing_assumptions
    from .engines import judge, judge_ftm
    out = Outcome()
    ftm_findings(old, new, policy, out)
    with status(f"checking {new.name}" + (" in the Alloy Analyzer" if engine != "python" else "") + "…"):
        judged = judge(new, Configuration.initial(new), engine, solver)
        ftm, _ = judge_ftm(new, engine)         # the head is judged as `reconf check` judges it
    broken = [d for d in ftm if d.is_error]
    out.safe, out.engines = judged.valid and not broken, judged.engines
    out.cases[:0] = report.assumption_cases(new.name, judged.python)
    out.diagnostics[:0] = ftm + [report.assumption_diagnostic(r) for r in judged.python.unsatisfied]
    base_failing = failing_assumptions(old, Configuration.initial(old))
    out.base_safe = not base_failing
    if not out.safe:
        failing = len(judged.python.unsatisfied)
        notes: tuple[str, ...] = ((f"{plural(failing, 'assumption')} {report.agree(failing, 'does', 'do')} not "
                                   f"hold; see above",) if failing else ())
        notes += ((f"{plural(len(broken), 'fault-tolerance rule')} {report.agree(len(broken), 'is', 'are')} "
                   f"broken; see above",) if broken else ())
        d = error("RC507", f"{new.name} is not safe: no migration to it is planned", new.span,
                  notes=notes + ((f"the base {old.name} is not safe either",) if base_failing else ()))
        out.fail("gate.policy", "a verified migration plan exists", d)
        return out
    if base_failing:
        allowed = ("--allow-unsafe-base" if allow_unsafe_base else
                   f"allow-unsafe-base = true in {policy.where}" if policy.allow_unsafe_base else None)
        unsafe_base_findings(old, new, base_failing, allowed, out)
        return out
    plan_findings(old, new, policy, engine != "python", solver, out)
    return out


# ---------------------------------------------------------------- reports

REPORT_FORMATS = ("json", "sarif", "github", "junit", "markdown")


def parse_reports(ctx: click.Context, param: click.Parameter, values: tuple[str, ...]) -> list[tuple[str, str]]:
    out = []
    for v in values:
        fmt, sep, path = v.partition("=")
        if not sep or fmt not in REPORT_FORMATS or not path:
            raise click.BadParameter(f"'{v}' is not FORMAT=FILE with FORMAT one of {', '.join(REPORT_FORMATS)}")
        out.append((fmt, path))
    return out


def write_reports(reports: list[tuple[str, str]], render: Callable[[str], str]) -> list[Diagnostic]:
    """Each report `render`ed in its format and written (atomically); what could not be written."""
    failed = []
    for fmt, path in reports:
        try:
            write_atomically(path, render(fmt))
        except CannotWrite as e:
            why = e.diagnostics[0].message.removeprefix(f"cannot write {path}: ")
            failed.append(error("RC511", f"cannot write the {fmt} report {path}: {why}",
                                Span.unknown("<command line>")))
    return failed


class ReportsNotWritten(Failure):
    """Some `--report` files could not be written (RC511); the others hold the gate's verdict."""


def write_failure_reports(reports: list[tuple[str, str]], diags: list[Diagnostic], base: str, head: str) -> None:
    """Bad input: every report file still holds a valid document, which says why nothing was judged."""
    from .gate_comment import failure_comment
    summary = plural(sum(1 for d in diags if d.is_error), "error")

    def render(fmt: str) -> str:
        if fmt == "json":
            return report.document("gate", "error", diags, base=base, head=head) + "\n"
        if fmt == "markdown":
            return failure_comment(base, head, diags)
        return formats.render(formats.Report("gate", "error", diags, formats.failure_cases("gate", diags), summary),
                              fmt)

    for d in write_reports(reports, render):
        click.echo(f"reconf gate: {d.message}", err=True)


# ---------------------------------------------------------------- the command

@click.command("gate")
@click.option("--base", "base", required=True, metavar="OLD",
              help="the deployed architecture: a path or git:REF:PATH (e.g. git:origin/main:robot.arch)")
@click.option("--head", "head", required=True, metavar="NEW", help="the proposed architecture: a path or git:REF:PATH")
@click.option("--policy", "policy_file", metavar="FILE",
              help="policy TOML, a path or git:REF:PATH (default: reconf.toml, or [tool.reconf] in pyproject.toml, "
                   "found from here)")
@click.option("--allow-unsafe-base", is_flag=True,
              help="when OLD is not safe (no plan from it exists), pass a safe NEW alone, with a warning: the fix "
                   "must be deployed by other means")
@click.option("--detailed-exitcode", is_flag=True,
              help="exit 0 when there is nothing to do, 3 when the change is safe and has steps (1 fail, 2 bad input)")
@click.option("--report", "reports", multiple=True, metavar="FORMAT=FILE", callback=parse_reports,
              help="also write the report as FORMAT (json, sarif, github, junit, markdown: a pull-request comment) "
                   "to FILE; repeatable, so that one run writes every output CI needs")
@format_option
@engine_option
@solver_option
@guarded("gate")
def gate_cmd(base: str, head: str, policy_file: Optional[str], allow_unsafe_base: bool, detailed_exitcode: bool,
             reports: list[tuple[str, str]], output_format: ReportFormat, engine: str, solver: str,
             sources: Sources) -> None:
    """Pass when NEW is safe and a verified migration plan from OLD to NEW exists within the policy.

    \b
    Policy keys ([tool.reconf] in pyproject.toml, or reconf.toml):
      max-disruption = N        Σ criticality × steps degraded, at most N
      never-degrade = [...]     COMPONENT.FUNCTIONALITY or FUNCTIONALITY never degraded
      keep-ftm = true | [...]   faults covered by these components' (or FTMs') mechanisms stay covered
      strategy = "default"      planning strategy
      allow-unsafe-base = true  as --allow-unsafe-base
    Every name must name something in NEW or OLD (RC508).
    Exit codes: 0 pass, 1 fail, 2 bad input; with --detailed-exitcode,
    0 nothing to do, 3 a safe change with steps.
    """
    try:
        run_gate(base, head, policy_file, allow_unsafe_base, detailed_exitcode, reports, output_format, engine,
                 solver, sources)
    except ReportsNotWritten:
        raise                           # the reports that were written hold the verdict: keep them
    except (DiagnosticError, Failure) as e:
        write_failure_reports(reports, e.diagnostics, base, head)
        raise
    except (EngineUnavailable, EnginesDisagree) as e:
        write_failure_reports(reports, [e.diagnostic], base, head)
        raise
    except (click.exceptions.Exit, click.ClickException):
        raise
    except Exception as e:  # the guard reports it; the files must say so too
        if not os.environ.get("RECONF_DEBUG"):
            write_failure_reports(reports, [report.internal_error(f"internal error: {type(e).__name__}: {e}")],
                                  base, head)
        raise


def gate_policy(policy_file: Optional[str], revs: Revisions, sources: Sources) -> Policy:
    if policy_file is None or not policy_file.startswith(GIT_PREFIX):
        return load_policy(policy_file, sources=sources)
    path = resolve(policy_file, revs, includes=False)
    return load_policy(path, shown=revs.rename(display_path(path)), origin=split_ref(policy_file)[0],
                       sources=sources)


def run_gate(base: str, head: str, policy_file: Optional[str], allow_unsafe_base: bool, detailed_exitcode: bool,
             reports: list[tuple[str, str]], output_format: ReportFormat, engine: str, solver: str,
             sources: Sources) -> None:
    from .gate_comment import comment
    with revisions() as revs:
        try:
            policy = gate_policy(policy_file, revs, sources)
            old = load([resolve(base, revs)], sources)
            new = load([resolve(head, revs)], sources)
            wrong = check_names(policy, old, new)
            if wrong:
                raise DiagnosticError(wrong)
        except DiagnosticError as e:
            rename_sources(sources, revs)
            raise DiagnosticError([revs.diagnostic(d) for d in e.diagnostics]) from None
        rename_sources(sources, revs)
        out = judge_change(old, new, policy, engine, solver, allow_unsafe_base)
        out.diagnostics = [revs.diagnostic(d) for d in out.diagnostics]
        out.cases = [replace(c, span=revs.span(c.span)) if c.span else c for c in out.cases]
    verdict = "pass" if out.passed else "fail"
    n = sum(1 for d in out.diagnostics if d.is_error)
    plan_line = f"; plan: {out.plan.summary()}" if out.plan is not None else ""
    if out.passed and out.plan is None:
        plan_line = "; the base is not safe: no plan from it, deploy by other means"
    line = f"{base} → {head}" + (f": {new.name} is safe{plan_line}, within {policy.where}" if out.passed else
                                 f": {plural(n, 'reason')}{plan_line}")
    human = f"[bold green]✓ gate passed[/] {line}" if out.passed else f"[bold red]✗ gate failed[/] {line}"
    rep = formats.Report("gate", verdict, out.diagnostics, out.cases, f"gate {verdict}: {line}")

    def json_doc() -> str:
        return report.document("gate", verdict, out.diagnostics, base=base, head=head, policy=policy.to_json(),
                               safe=out.safe, base_safe=out.base_safe, engines=out.engines, plan=out.plan_doc)

    def render(fmt: str) -> str:
        if fmt == "json":
            return json_doc() + "\n"
        if fmt == "markdown":
            summary = (f"{new.name} is safe, within {policy.where}" if out.passed else
                       f"{plural(n, 'reason')} the change does not pass")
            return comment(verdict=verdict, base=base, head=head, diagnostics=out.diagnostics, summary=summary,
                           plan=out.plan)
        return formats.render(rep, fmt)

    failed = write_reports(reports, render)
    if failed:
        raise ReportsNotWritten(failed)
    emit_report(rep, output_format, sources, json_doc, human)
    if not out.passed:
        sys.exit(EXIT_UNSAFE)
    sys.exit(EXIT_CHANGES if detailed_exitcode and not out.nothing_to_do else EXIT_OK)


def rename_sources(sources: Sources, revs: Revisions) -> None:
    """The texts read from revisions under their work-tree names; a file of the work tree that
    was read too keeps its own text (the findings on it are on its lines)."""
    own = {key for key in sources.texts if revs.rename(key) == key}
    for key in list(sources.texts):
        new = revs.rename(key)
        if new == key:
            continue
        text = sources.texts.pop(key)
        if new not in own:
            sources.texts[new] = text
