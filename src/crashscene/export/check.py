"""ASAM quality checkers on exported files: OpenDRIVE (`qc_opendrive`) and OpenSCENARIO XML (`qc_openscenario`).

Runs a checker bundle the way its command line does (a config naming the input file and a
result file, every checker of the bundle, none selected), in this process so that many files
share one import of the bundle, and reads back the `.xqar` result: per checker its status
(completed, skipped, error) and issues (level 1 error, 2 warning, 3 information).

The bundles (`pip install asam-qc-opendrive asam-qc-openscenarioxml`, the `test` extra) are
imported only when a check runs.
"""
from __future__ import annotations

import logging
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from crashscene.export.errors import ExportError

ERROR, WARNING, INFORMATION = 1, 2, 3  # ASAM issue levels
BUNDLES = {".xodr": ("qc_opendrive", "xodrBundle"), ".xosc": ("qc_openscenario", "xoscBundle")}


@dataclass(frozen=True)
class Issue:
    """One finding: level (1 error, 2 warning, 3 information), the rule's text and where (row, column)."""

    checker: str
    level: int
    description: str
    locations: tuple[str, ...] = ()


@dataclass(frozen=True)
class Checker:
    checker_id: str
    status: str  # completed | skipped | error
    summary: str


@dataclass
class CheckReport:
    """What a checker bundle said about one file."""

    path: Path
    bundle: str
    checkers: list[Checker] = field(default_factory=list)
    issues: list[Issue] = field(default_factory=list)

    @property
    def errors(self) -> list[Issue]:
        return [i for i in self.issues if i.level == ERROR]

    @property
    def not_completed(self) -> list[Checker]:
        """Checkers that did not run to completion (skipped on a failed precondition or version, or crashed)."""
        return [c for c in self.checkers if c.status != "completed"]

    @property
    def version_skipped(self) -> list[Checker]:
        """Checkers skipped only because their rule does not apply to the file's declared version."""
        return [c for c in self.not_completed if c.status == "skipped" and c.summary.startswith("Version ")]

    @property
    def failed(self) -> list[Checker]:
        """Checkers skipped because a prerequisite failed, or that crashed."""
        return [c for c in self.not_completed if c not in self.version_skipped]

    @property
    def ok(self) -> bool:
        """No error-level issue and no checker skipped for a failed prerequisite."""
        return not self.errors and not self.failed

    def describe(self) -> str:
        """Human-readable summary of errors and checkers that did not complete."""
        lines = [f"{self.path} ({self.bundle}): {len(self.errors)} error(s), {len(self.failed)} checker(s) failed "
                 f"or skipped on a failed prerequisite, {len(self.version_skipped)} not applicable to the version, "
                 f"of {len(self.checkers)}"]
        lines += [f"  error [{i.checker}] {i.description} {'; '.join(i.locations)}" for i in self.errors]
        lines += [f"  {c.status} [{c.checker_id}] {c.summary}" for c in self.not_completed]
        return "\n".join(lines)


def _bundle_module(suffix: str):
    try:
        package, name = BUNDLES[suffix]
    except KeyError:
        raise ExportError(f"no ASAM checker bundle for {suffix!r} files; allowed: {', '.join(BUNDLES)}") from None
    try:
        main = __import__(f"{package}.main", fromlist=["run_checks"])
        from qc_baselib import Configuration, Result
    except ImportError as exc:
        raise ExportError(f"the ASAM checker {package} is not installed ({exc}); "
                          "pip install asam-qc-opendrive asam-qc-openscenarioxml (the `test` extra)") from exc
    return main, name, Configuration, Result


def check_file(path: Path) -> CheckReport:
    """Run the ASAM checker bundle for `path` (.xodr or .xosc) with all its checkers; return its findings."""
    path = Path(path).resolve()
    main, name, Configuration, Result = _bundle_module(path.suffix)
    root = logging.getLogger()
    level = root.level
    with tempfile.TemporaryDirectory(prefix="crashscene-qc-") as tmp:
        config_path, result_path = Path(tmp) / "config.xml", Path(tmp) / "result.xqar"
        config_xml = ET.Element("Config")
        ET.SubElement(config_xml, "Param", name="InputFile", value=str(path))
        bundle = ET.SubElement(config_xml, "CheckerBundle", application=name)
        ET.SubElement(bundle, "Param", name="resultFile", value=str(result_path))
        ET.ElementTree(config_xml).write(config_path)
        config = Configuration()
        config.load_from_file(xml_file_path=str(config_path))
        result = Result()
        result.register_checker_bundle(name=main.constants.BUNDLE_NAME, description=f"{name} (crashscene)",
                                       version=main.constants.BUNDLE_VERSION, summary="")
        result.set_result_version(version=main.constants.BUNDLE_VERSION)
        root.setLevel(logging.WARNING)  # the bundles log every step at INFO on the root logger
        try:
            main.run_checks(config, result)
        finally:
            root.setLevel(level)
        result.copy_param_from_config(config)
        result.write_to_file(str(result_path), generate_summary=True)
        return read_result(result_path, path, name)


def read_result(result_path: Path, input_path: Path, bundle: str) -> CheckReport:
    """Parse a checker bundle's `.xqar` result file."""
    report = CheckReport(path=input_path, bundle=bundle)
    for checker in ET.parse(result_path).getroot().iter("Checker"):
        cid = checker.get("checkerId", "?")
        report.checkers.append(Checker(cid, checker.get("status", "missing"), checker.get("summary", "")))
        for issue in checker.iter("Issue"):
            where = tuple(
                " ".join(filter(None, [loc.get("description"),
                                       *(f"row {f.get('row')}" for f in loc.iter("FileLocation")),
                                       *(f"xpath {x.get('xpath')}" for x in loc.iter("XMLLocation"))]))
                for loc in issue.iter("Locations"))
            report.issues.append(Issue(cid, int(issue.get("level", "1")), issue.get("description", ""), where))
    return report
