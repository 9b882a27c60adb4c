"""The dry run: a plan replayed against its embedded model, every state judged, no ROS."""
from __future__ import annotations

from typing import Any, Optional

from .context import Writer
from .plan_states import PlanStates, State
from .semantics import Model
from .steps import Step, plan_steps, restoring


def _walk(model: Model, steps: list[Step], recorded: PlanStates,
          out: Writer) -> tuple[list[tuple[str, State]], Optional[tuple[int, Step, str]], bool]:
    """Every state the steps reach, labelled; the first step refused, if one is; whether each
    state is the one the document records."""
    state = recorded[0] if recorded else State([], [], [])
    rows, agree = [("  0.   initial state", state)], True
    for i, step in enumerate(steps, 1):
        why = model.refusal(state, step)
        if why:
            return rows, (i, step, why), agree
        state = model.effect(state, step)
        if i < len(recorded) and recorded[i].key() != state.key():
            print(f"dry run: after step {i} the embedded plan records a different state than the steps give",
                  file=out)
            agree = False
        rows.append((step.label(i), state))
    return rows, None, agree


def _verdict(model: Model, steps: list[Step], restore: int, i: int, st: State) -> tuple[str, list[str]]:
    """`safe`, `UNSAFE`, or `restoring`: a state before the end of a recovery's first degrades
    that fails only on functionalities a later one of them degrades (docs/soundness.md#restoring-validity)."""
    bad = model.failing(st)
    if not bad:
        return "safe", []
    words = [f"{c}.{f} assumes {a}, which does not hold" for c, f, a in bad]
    later = {(s.component, s.functionality) for s in steps[i:restore] if s.action == "degrade"}
    if i < restore and all((c, f) in later for c, f, _ in bad):
        return "restoring", words
    return "UNSAFE", words


def replay(doc: dict[str, Any], out: Writer) -> bool:
    """Replay the plan from its first state; print every state; True when all are safe (or, in a
    recovery's first degrades, restoring validity)."""
    model, steps, restore = Model(doc["model"]), plan_steps(doc), restoring(doc)
    rows, refused, ok = _walk(model, steps, PlanStates(doc["plan"]), out)
    unsafe = []
    for i, (text, st) in enumerate(rows):
        verdict, bad = _verdict(model, steps, restore, i, st)
        degraded = ", ".join(f"{c}.{f}" for c, f in sorted(st.degraded) if c in st.components) or "-"
        print(f"{text:<60} [{verdict}]  degraded: {degraded}", file=out)
        for reason in bad:
            print(f"       {reason}", file=out)
        if verdict == "UNSAFE":
            unsafe.append(i)
    if refused is not None:
        i, step, why = refused
        print(f"{step.label(i):<60} [REFUSED]  {why}", file=out)
        print(f"dry run: step {i} ({step.describe()}) cannot run: {why}", file=out)
        ok = False
    if unsafe:
        where = ", ".join(f"step {i} ({steps[i - 1].describe()})" if i else "the initial state" for i in unsafe)
        print(f"dry run: UNSAFE after {where}", file=out)
        ok = False
    if ok and restore:
        print(f"dry run: steps 1-{restore} restore validity; " if restore > 1 else
              "dry run: step 1 restores validity; ", end="", file=out)
        print(f"the {len(rows) - restore} states from there are safe" if len(rows) - restore != 1 else
              "the 1 state from there is safe", file=out)
    elif ok:
        print("dry run: " + (f"all {len(rows)} states are safe" if len(rows) != 1 else "the 1 state is safe"),
              file=out)
    return ok
