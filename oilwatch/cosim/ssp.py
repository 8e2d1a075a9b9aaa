"""SSP 1.0 archives: write a system (FMUs, parameter bindings, connections, default experiment),
read one back into a :class:`~oilwatch.cosim.master.SystemDescription`.

The archive holds ``SystemStructure.ssd`` and ``resources/<name>.fmu``. Parameters are inline
``ssd:ParameterBinding`` elements with ``ssv:ParameterSet`` values (SSP 1.0, section 5.3.7). SSP
1.0's ``DefaultExperiment`` has no step size; the macro step goes into the Open Simulation
Platform's annotation (``com.opensimulationplatform``: ``osp:FixedStepAlgorithm baseStepSize``),
which libcosim reads and other tools ignore.
"""

from __future__ import annotations

import shutil
import tempfile
import zipfile
from contextlib import contextmanager
from pathlib import Path
from xml.etree import ElementTree as ET

from fmpy import read_model_description

from oilwatch.outputs.atomic import atomic_path

from .connections import Connection, same_name_connections
from .errors import SystemDescriptionError
from .master import FmuSpec, Master, SystemDescription

NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "osp": "https://opensimulationplatform.com/SSP/OSPAnnotations",
}
OSP_ANNOTATION = "com.opensimulationplatform"
SSD_NAME = "SystemStructure.ssd"
_FMI_TO_SSC = {"Real": "Real", "Integer": "Integer", "Boolean": "Boolean", "String": "String"}
_FMI_TO_SSC |= {"Float64": "Real", "Int32": "Integer"}  # FMI 3.0 types of oilwatch's FMI 3.0 FMUs

for _prefix, _uri in NS.items():
    ET.register_namespace(_prefix, _uri)


def _q(prefix: str, tag: str) -> str:
    return f"{{{NS[prefix]}}}{tag}"


def _value_text(type_name: str, value) -> str:
    if type_name == "Real":
        return repr(float(value))
    if type_name in ("Integer", "Enumeration"):
        return str(int(value))
    if type_name == "Boolean":
        return "true" if bool(value) else "false"
    return str(value)


def _parse_value(type_name: str, text: str):
    if type_name == "Real":
        return float(text)
    if type_name == "Integer":
        return int(text)
    if type_name == "Boolean":
        return text.strip().lower() in ("true", "1")
    return text


def _descriptions(system: SystemDescription) -> dict[str, object]:
    result = {}
    for spec in system.fmus:
        path = Path(spec.path)
        if not path.is_file():
            raise SystemDescriptionError(f"FMU file {path} (instance '{spec.name}') does not exist")
        try:
            result[spec.name] = read_model_description(str(path), validate=False)
        except Exception as error:
            raise SystemDescriptionError(
                f"FMU file {path} (instance '{spec.name}') is corrupt ({error})"
            ) from None
    return result


def check_system(system: SystemDescription) -> None:
    """Check FMUs, parameter names and connection connectors against the model descriptions.

    Cheaper than loading: no FMU is instantiated. Raises SystemDescriptionError naming the problem.
    """
    descriptions = _descriptions(system)
    variables = {name: {v.name: v for v in md.modelVariables} for name, md in descriptions.items()}
    for spec in system.fmus:
        for parameter in spec.parameters:
            if parameter not in variables[spec.name]:
                raise SystemDescriptionError(
                    f"parameter {parameter!r}: FMU instance '{spec.name}' "
                    f"({Path(spec.path).name}) has no such variable"
                )
    for c in system.connections or []:
        for element, connector, causality in (
            (c.start_element, c.start_connector, "output"),
            (c.end_element, c.end_connector, "input"),
        ):
            if element not in variables:
                raise SystemDescriptionError(
                    f"connection {c}: no FMU instance named {element!r} (instances: {sorted(variables)})"
                )
            variable = variables[element].get(connector)
            if variable is None or variable.causality != causality:
                candidates = sorted(n for n, v in variables[element].items() if v.causality == causality)
                path = Path(next(s.path for s in system.fmus if s.name == element)).name
                raise SystemDescriptionError(
                    f"connection {c}: FMU instance '{element}' ({path}) has no {causality} "
                    f"connector {connector!r}; its {causality}s are {candidates}"
                )


def _component(spec: FmuSpec, md, source: str) -> ET.Element:
    component = ET.Element(
        _q("ssd", "Component"),
        {"name": spec.name, "type": "application/x-fmu-sharedlibrary", "source": source},
    )
    connectors = ET.SubElement(component, _q("ssd", "Connectors"))
    for v in md.modelVariables:
        wanted = v.causality in ("input", "output") or v.name in spec.parameters
        if not wanted or v.type not in _FMI_TO_SSC:
            continue
        kind = v.causality if v.causality in ("input", "output", "parameter") else "parameter"
        connector = ET.SubElement(connectors, _q("ssd", "Connector"), {"name": v.name, "kind": kind})
        ET.SubElement(connector, _q("ssc", _FMI_TO_SSC[v.type]), {"unit": v.unit} if v.unit else {})
    if spec.parameters:
        types = {v.name: v.type for v in md.modelVariables}
        bindings = ET.SubElement(component, _q("ssd", "ParameterBindings"))
        binding = ET.SubElement(bindings, _q("ssd", "ParameterBinding"))
        values = ET.SubElement(binding, _q("ssd", "ParameterValues"))
        parameter_set = ET.SubElement(
            values, _q("ssv", "ParameterSet"), {"version": "1.0", "name": f"{spec.name}_parameters"}
        )
        parameters = ET.SubElement(parameter_set, _q("ssv", "Parameters"))
        for name, value in spec.parameters.items():
            parameter = ET.SubElement(parameters, _q("ssv", "Parameter"), {"name": name})
            ET.SubElement(
                parameter,
                _q("ssv", _FMI_TO_SSC[types[name]]),
                {"value": _value_text(_FMI_TO_SSC[types[name]], value)},
            )
    return component


def _units(descriptions) -> ET.Element:
    """``ssd:Units`` with every FMU unit (same name, same SI definition) the connectors use."""
    element = ET.Element(_q("ssd", "Units"))
    seen: dict[str, dict[str, str]] = {}
    for md in descriptions:
        for unit in md.unitDefinitions:
            base = unit.baseUnit
            attrib = {}
            if base is not None:
                for key in ("kg", "m", "s", "A", "K", "mol", "cd", "rad"):
                    if getattr(base, key, 0):
                        attrib[key] = str(getattr(base, key))
                if base.factor not in (None, 1.0):
                    attrib["factor"] = repr(float(base.factor))
                if base.offset not in (None, 0.0):
                    attrib["offset"] = repr(float(base.offset))
            if unit.name in seen:
                if seen[unit.name] != attrib:
                    raise SystemDescriptionError(f"unit {unit.name!r} is defined differently")
                continue
            seen[unit.name] = attrib
            ssc_unit = ET.SubElement(element, _q("ssc", "Unit"), {"name": unit.name})
            ET.SubElement(ssc_unit, _q("ssc", "BaseUnit"), attrib)
    return element


def write_ssp(path: str | Path, system: SystemDescription) -> Path:
    """Write ``system`` as an SSP 1.0 archive at ``path``; connections None are resolved by name.

    The FMU files are copied into ``resources/`` under their file names (instances sharing an FMU
    share the file).
    """
    check_system(system)
    descriptions = _descriptions(system)
    connections = system.connections
    if connections is None:
        connections = same_name_connections({name: md.modelVariables for name, md in descriptions.items()})
    sources: dict[str, Path] = {}
    for spec in system.fmus:
        name = Path(spec.path).name
        if name in sources and sources[name].resolve() != Path(spec.path).resolve():
            raise SystemDescriptionError(f"two different FMU files are both called {name}")
        sources[name] = Path(spec.path)

    root = ET.Element(_q("ssd", "SystemStructureDescription"), {"version": "1.0", "name": system.name})
    ssd_system = ET.SubElement(root, _q("ssd", "System"), {"name": system.name})
    elements = ET.SubElement(ssd_system, _q("ssd", "Elements"))
    for spec in system.fmus:
        source = f"resources/{Path(spec.path).name}"
        elements.append(_component(spec, descriptions[spec.name], source))
    ssd_connections = ET.SubElement(ssd_system, _q("ssd", "Connections"))
    for c in connections:
        ET.SubElement(
            ssd_connections,
            _q("ssd", "Connection"),
            {
                "startElement": c.start_element,
                "startConnector": c.start_connector,
                "endElement": c.end_element,
                "endConnector": c.end_connector,
            },
        )
    units = _units(descriptions.values())
    if len(units):
        root.append(units)
    experiment = {"startTime": repr(float(system.start_time))}
    if system.stop_time is not None:
        experiment["stopTime"] = repr(float(system.stop_time))
    default = ET.SubElement(root, _q("ssd", "DefaultExperiment"), experiment)
    if system.step_size is not None:
        annotations = ET.SubElement(default, _q("ssd", "Annotations"))
        annotation = ET.SubElement(annotations, _q("ssc", "Annotation"), {"type": OSP_ANNOTATION})
        algorithm = ET.SubElement(annotation, _q("osp", "Algorithm"))
        ET.SubElement(algorithm, _q("osp", "FixedStepAlgorithm"), {"baseStepSize": repr(system.step_size)})
    ET.indent(root)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as temporary:  # whole or not at all (oilwatch.outputs.atomic)
        with zipfile.ZipFile(temporary, "w", zipfile.ZIP_DEFLATED) as archive:
            archive.writestr(SSD_NAME, ET.tostring(root, encoding="UTF-8", xml_declaration=True))
            for name, source in sources.items():
                archive.write(source, f"resources/{name}")
    return path


def _parse_ssd(text: bytes, folder: Path, origin: str) -> SystemDescription:
    try:
        root = ET.fromstring(text)
    except ET.ParseError as error:
        raise SystemDescriptionError(f"{origin}: {SSD_NAME} is not valid XML ({error})") from None
    ssd_system = root.find("ssd:System", NS)
    if root.tag != _q("ssd", "SystemStructureDescription") or ssd_system is None:
        raise SystemDescriptionError(f"{origin}: {SSD_NAME} is not an SSP 1.0 system structure")
    fmus = []
    for component in ssd_system.findall("ssd:Elements/ssd:Component", NS):
        name, source = component.get("name"), component.get("source", "")
        fmu_path = folder / source
        if not fmu_path.is_file():
            raise SystemDescriptionError(
                f"{origin}: component '{name}' names source {source!r}, which the archive lacks"
            )
        parameters = {}
        for parameter in component.findall(
            "ssd:ParameterBindings/ssd:ParameterBinding/ssd:ParameterValues/"
            "ssv:ParameterSet/ssv:Parameters/ssv:Parameter",
            NS,
        ):
            value = next(iter(parameter))
            type_name = value.tag.rsplit("}", 1)[-1]
            parameters[parameter.get("name")] = _parse_value(type_name, value.get("value", ""))
        fmus.append(FmuSpec(name, fmu_path, parameters))
    connections = []
    for c in ssd_system.findall("ssd:Connections/ssd:Connection", NS):
        if c.get("startElement") is None or c.get("endElement") is None:
            raise SystemDescriptionError(f"{origin}: system-level connectors are not supported")
        connections.append(
            Connection(
                c.get("startElement"),
                c.get("startConnector"),
                c.get("endElement"),
                c.get("endConnector"),
            )
        )
    default = root.find("ssd:DefaultExperiment", NS)
    start, stop, step = 0.0, None, None
    if default is not None:
        start = float(default.get("startTime", 0.0))
        stop = float(default.get("stopTime")) if default.get("stopTime") else None
        fixed = default.find("ssd:Annotations/ssc:Annotation/osp:Algorithm/osp:FixedStepAlgorithm", NS)
        if fixed is not None:
            step = float(fixed.get("baseStepSize"))
    system = SystemDescription(fmus, connections, start, stop, step, name=root.get("name", "system"))
    check_system(system)
    return system


@contextmanager
def open_ssp(path: str | Path):
    """Extract an .ssp and yield its SystemDescription (FMU paths valid inside the ``with``)."""
    path = Path(path)
    if not path.is_file():
        raise SystemDescriptionError(f"SSP file {path} does not exist")
    if not zipfile.is_zipfile(path):
        raise SystemDescriptionError(f"SSP file {path} is corrupt: not a ZIP archive")
    folder = Path(tempfile.mkdtemp(prefix="oilwatch_ssp_"))
    try:
        with zipfile.ZipFile(path) as archive:
            if SSD_NAME not in archive.namelist():
                raise SystemDescriptionError(f"SSP file {path} has no {SSD_NAME}")
            archive.extractall(folder)
        yield _parse_ssd((folder / SSD_NAME).read_bytes(), folder, str(path))
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def master_from_ssp(path: str | Path) -> Master:
    """A :class:`Master` for the system in an .ssp (its FMUs are extracted by the Master)."""
    with open_ssp(path) as system:
        return Master(system)
