"""FTM benchmark: N services, each protected by PBR(TR), expanded and checked; then a
transition of one of them planned and verified.

    python -m bench.bench_ftm [--services 20] [--ftm "PBR(TR)"] [--to "SEC(PBR(TR))"] [--no-alloy]

Figures (one process, after imports):
  parse    load the generated .arch text (N servers, N clients, 2 hosts)
  expand   `checker.ftm.expand.expand` (every FTM into its computation graph)
  rules    `checker.ftm.diagnose.ftm_diagnostics` (the RC4xx rules)
  check    `checker.semantic_model.semantics.evaluate` on the expanded architecture
  plan     `checker.ftm.transition.plan_transition` for service 0 (planning, suspension, and the
           step-by-step verification every plan passes in the Python engine)
  alloy    the same plan verified in the Alloy Analyzer as `reconf plan transition` does
           (`checker.planning.alloy_verify.alloy_evidence`): every state of the slice the plan can affect
           valid and lossless, every step an instance of its action, and every other component
           judged once in the first state; JVM start shown apart
  check wall  `reconf check FILE` in a fresh process: both engines, the FTM rules in Alloy too
  wall     `reconf plan transition server0 TO` in a fresh process, all of the above included

Targets: expand + check of 20 × PBR(TR) < 3 s; one transition planned and verified < 5 s
(in process, and as the command's wall time).
"""
from __future__ import annotations

import argparse
import time

from checker.ftm.diagnose import ftm_diagnostics
from checker.ftm.expand import expand
from checker.ftm.library import compose
from checker.ftm.transition import parse_ftm, plan_transition
from checker.semantic_model.config import Configuration
from checker.semantic_model.semantics import evaluate
from reconf_dsl.loader import load_text


def generate(n: int, ftm: str) -> str:
    comp = compose(parse_ftm(ftm))[0]
    assert comp is not None, ftm
    faults = ", ".join(sorted(comp.covers))
    lines = ["system ftm_bench", "message Reply = std_msgs/msg/String",
             "host master { cpus: 1 bandwidth: high }", "host slave { cpus: 1 bandwidth: high }"]
    for i in range(n):
        lines += [f"component server{i} {{", f"  faults {faults}",
                  "  application deterministic, state_access", f"  ftm {ftm} on master, slave",
                  "  output reply: Reply", "  functionality serve (reply) {",
                  "    normal { reply: Reply @ 10 Hz }", "    degraded { reply: nothing }", "  }", "}",
                  f"component client{i} {{", "  input reply: Reply @ 10 Hz", "  functionality use (reply) {",
                  "    normal { assume Reply @ 10 Hz }", "    degraded { }", "  }", "}",
                  f"service /compute{i}: Reply @ 10 Hz {{ server{i}.reply -> client{i}.reply }}"]
    return "\n".join(lines) + "\n"


def _cli_wall(text: str, to: str, args: tuple[str, ...] = ()) -> float:
    """Wall seconds of `reconf plan transition server0 TO -f FILE` in a fresh process (JVM start,
    planning, Python and Alloy verification, output); with `args`, of `reconf ARGS FILE`."""
    import os
    import subprocess
    import sys
    import tempfile
    with tempfile.NamedTemporaryFile("w", suffix=".arch", delete=False) as f:
        f.write(text)
    reconf = os.path.join(os.path.dirname(sys.executable), "reconf")
    cmd = [reconf] if os.path.exists(reconf) else [sys.executable, "-m", "checker"]
    try:
        start = time.perf_counter()
        line = [*args, f.name] if args else ["plan", "transition", "server0", to, "-f", f.name]
        proc = subprocess.run(cmd + line, capture_output=True, text=True)
        wall = time.perf_counter() - start
    finally:
        os.unlink(f.name)
    if proc.returncode != 0:
        raise SystemExit(f"reconf {' '.join(line[:2])} failed ({proc.returncode}): {proc.stderr.strip()[-300:]}")
    return wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--services", type=int, default=20)
    ap.add_argument("--ftm", default="PBR(TR)")
    ap.add_argument("--to", default="SEC(PBR(TR))", help="the FTM service 0 moves to")
    ap.add_argument("--no-alloy", action="store_true", help="plan and verify with the Python engine only")
    args = ap.parse_args()
    text = generate(args.services, args.ftm)
    t0 = time.perf_counter()
    system = load_text(text, "<bench>")
    t1 = time.perf_counter()
    expanded, infos = expand(system)
    t2 = time.perf_counter()
    diags = ftm_diagnostics(system)
    t3 = time.perf_counter()
    ev = evaluate(expanded, Configuration.initial(expanded), explain=False)
    t4 = time.perf_counter()
    assert ev.valid and not diags
    tr = plan_transition(system, "server0", args.to)
    t5 = time.perf_counter()
    rows = [("services", str(args.services)), ("ftm", f"{args.ftm} → {args.to} (service 0)"),
            ("components expanded", str(len(expanded.components))),
            ("connectors expanded", str(len(expanded.connectors))),
            ("parse s", f"{t1 - t0:.3f}"), ("expand s", f"{t2 - t1:.3f}"), ("rules s", f"{t3 - t2:.3f}"),
            ("check s", f"{t4 - t3:.3f}"), ("expand+rules+check s", f"{t4 - t1:.3f}"),
            ("plan+verify s", f"{t5 - t4:.3f}"), ("plan steps", str(len(tr.plan.steps))),
            ("disruption", str(tr.plan.disruption)), ("suspended", ", ".join(tr.suspended) or "-")]
    ok_plan = True
    checked = 0.0
    if not args.no_alloy:
        from checker.alloy import get_backend
        from checker.planning.alloy_verify import alloy_evidence
        get_backend()
        t6 = time.perf_counter()
        evidence = alloy_evidence(tr.plan)
        t7 = time.perf_counter()
        sl = evidence.get("slice", {})
        rows += [("JVM start s", f"{t6 - t5:.3f}"),
                 ("alloy slice", f"{sl.get('components', '-')} components; {sl.get('judged_once', 0)} judged once"),
                 ("alloy valid, lossless", f"{evidence['valid']}, {bool(evidence.get('lossless'))}"),
                 ("alloy s (commands)", f"{evidence['seconds']:.3f}"), ("alloy s (total)", f"{t7 - t6:.3f}"),
                 ("planned and verified s", f"{t7 - t4:.3f}")]
        checked = _cli_wall(text, args.to, ("check",))
        rows.append(("reconf check wall s (both engines, FTM rules in Alloy too)", f"{checked:.3f}"))
        wall = _cli_wall(text, args.to)
        rows.append(("reconf plan transition wall s", f"{wall:.3f}"))
        ok_plan = t7 - t4 < 5 and wall < 5 and bool(evidence["valid"])
    else:
        ok_plan = t5 - t4 < 5
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")
    print(f"targets: expand+check < 3 s: {'ok' if t4 - t1 < 3 and checked < 3 else 'MISSED'}; "
          f"planned and verified < 5 s: {'ok' if ok_plan else 'MISSED'}")
    del infos


if __name__ == "__main__":
    main()
