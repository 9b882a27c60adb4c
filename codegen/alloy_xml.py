"""An instance of an evaluation module as the analyzer's instance XML (what it writes for a
solution and reads back with A4SolutionReader): every sig of the module's table
(codegen.alloy_module.EvaluationSig) with its own atoms, every field with its tuples. Atom
names are `codegen.alloy.mangle`d or generated (letters, digits and `_`), so nothing needs
escaping."""
from __future__ import annotations

from typing import Sequence

from .alloy_module import EVALUATION_SIGS, EvaluationSig, InstanceData

_HEAD = ('<alloy><instance bitwidth="0" maxseq="0" mintrace="1" maxtrace="1" tracelength="1" backloop="0" '
         'command="evaluate" filename="">\n<sig label="univ" ID="0" builtin="yes"/>\n')


def _atoms(atoms: Sequence[str]) -> str:
    return "".join(f'<atom label="{a}"/>' for a in atoms)


def _tuples(tuples: Sequence[tuple[str, ...]]) -> str:
    """`<tuple>` elements; pairs (nearly every field) written in one format each, the fastest."""
    return "".join(f'<tuple><atom label="{t[0]}"/><atom label="{t[1]}"/></tuple>' if len(t) == 2
                   else f"<tuple>{_atoms(t)}</tuple>" for t in tuples)


def instance_xml(data: InstanceData, sigs: Sequence[EvaluationSig] = EVALUATION_SIGS) -> str:
    """`data` as instance XML, for `A4SolutionReader.read` with the sigs of the module whose
    table is `sigs`."""
    ids = {"univ": 0, **{sig.name: i for i, sig in enumerate(sigs, start=1)}}
    out = [_HEAD]
    for sig in sigs:
        own = _atoms(data.atoms.get(sig.name, ()))
        if sig.subset:
            out.append(f'<sig label="this/{sig.name}" ID="{ids[sig.name]}"><type ID="{ids[sig.parent]}"/>{own}</sig>\n')
        else:
            out.append(f'<sig label="this/{sig.name}" ID="{ids[sig.name]}" parentID="{ids[sig.parent or "univ"]}">'
                       f'{own}</sig>\n')
    field_id = len(ids)
    for sig in sigs:
        for name, target in sig.fields:
            tuples = _tuples(data.fields.get(name, ()))
            out.append(f'<field label="{name}" ID="{field_id}" parentID="{ids[sig.name]}">{tuples}'
                       f'<types><type ID="{ids[sig.name]}"/><type ID="{ids[target]}"/></types></field>\n')
            field_id += 1
    out.append("</instance></alloy>\n")
    return "".join(out)
