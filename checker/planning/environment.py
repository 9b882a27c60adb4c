"""The environment in a migration. The environment is the world around the system: no
action changes it, so a migration's plan runs in the deployed architecture's environment,
and a target that relies on a guarantee only the new architecture declares cannot be
reached (docs/soundness.md, "The environment in a migration")."""
from __future__ import annotations

from dataclasses import replace as dc_replace

from checker.semantic_model.actions import failing_assumptions, satisfies
from checker.semantic_model.config import Configuration
from reconf_dsl.ir import System


def missing_environment(old: System, new: System, old_name: str = "the deployed architecture",
                        new_name: str = "the target") -> list[str]:
    """Why `new`, deployed in `old`'s environment, is unsafe where in its own it is not:
    one reason per assumption that only `new`'s environment guarantees. [] when none."""
    in_old_world = dc_replace(new, environment=old.environment)
    reasons = []
    for comp, func, asm in failing_assumptions(in_old_world, Configuration.initial(new)):
        only_new = [e for e in new.environment if satisfies(e.guarantee, asm)]
        for e in only_new[:1]:
            where = f"{e.span.file}:{e.span.line}" if e.span.line else e.span.file
            reasons.append(f"{comp}.{func} assumes {asm}, which only {new_name}'s environment guarantees "
                           f"(environment {e.name}: {e.guarantee}, {where}); a migration runs in the environment "
                           f"of {old_name}, which no action changes: if the world already provides it, declare "
                           f"`environment {e.name}: {e.guarantee}` in {old_name}")
    return reasons
