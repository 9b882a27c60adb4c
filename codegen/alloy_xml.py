"""An instance of the evaluation module as the analyzer's instance XML (what it writes for a
solution and reads back with A4SolutionReader): every sig of EVALUATION_SIGS with its own
atoms, every field with its tuples. Atom names are `codegen.alloy.mangle`d (letters, digits
and `_`), so nothing needs escaping."""
from __future__ import annotations

from .alloy_module import EVALUATION_SIGS, InstanceData

# sig IDs by name; 0 is univ, the parent of every top-level sig
_IDS = {"univ": 0, **{sig.name: i for i, sig in enumerate(EVALUATION_SIGS, start=1)}}
_HEAD = ('<alloy><instance bitwidth="0" maxseq="0" mintrace="1" maxtrace="1" tracelength="1" backloop="0" '
         'command="evaluate" filename="">\n<sig label="univ" ID="0" builtin="yes"/>\n')


def _atoms(atoms: tuple[str, ...]) -> str:
    return "".join(f'<atom label="{a}"/>' for a in atoms)


def instance_xml(data: InstanceData) -> str:
    """`data` as instance XML, for `A4SolutionReader.read` with the evaluation module's sigs."""
    out = [_HEAD]
    field_id = len(_IDS)
    for sig in EVALUATION_SIGS:
        own = data.atoms.get(sig.name, ())
        if sig.subset:
            out.append(f'<sig label="this/{sig.name}" ID="{_IDS[sig.name]}"><type ID="{_IDS[sig.parent]}"/>'
                       f'{_atoms(own)}</sig>\n')
        else:
            out.append(f'<sig label="this/{sig.name}" ID="{_IDS[sig.name]}" parentID="{_IDS[sig.parent or "univ"]}">'
                       f'{_atoms(own)}</sig>\n')
    for sig in EVALUATION_SIGS:
        for name, target in sig.fields:
            tuples = "".join(f"<tuple>{_atoms(t)}</tuple>" for t in data.fields.get(name, ()))
            out.append(f'<field label="{name}" ID="{field_id}" parentID="{_IDS[sig.name]}">{tuples}'
                       f'<types><type ID="{_IDS[sig.name]}"/><type ID="{_IDS[target]}"/></types></field>\n')
            field_id += 1
    out.append("</instance></alloy>\n")
    return "".join(out)
