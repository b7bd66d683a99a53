"""JUnit XML for CI users: one test case per scenario.

A scenario's test case fails when, in `test` mode, some variation ends in a
rule violation by the ADS under test or in a collision; it errors when the case
could not be prepared or simulated; it is skipped when no test-mode run exists.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET


def junit_xml(cases: list[dict], seconds: float = 0.0) -> str:
    suite = ET.Element("testsuite", name="crashscene", tests=str(len(cases)))
    failures = errors = skipped = 0
    for case in cases:
        tc = ET.SubElement(suite, "testcase", classname=f"crashscene.{case['case_id']}",
                           name=case.get("scenario_id") or case["case_id"])
        props = ET.SubElement(tc, "properties")
        for mode, run in case.get("modes", {}).items():
            ET.SubElement(props, "property", name=f"{mode}.variations", value=str(run["variations"]))
            ET.SubElement(props, "property", name=f"{mode}.reproduction_rate", value=str(run["reproduction_rate"]))
            for verdict, count in sorted(run["verdicts"].items()):
                ET.SubElement(props, "property", name=f"{mode}.{verdict}", value=str(count))
        if case["status"] != "ok":
            errors += 1
            kind = "IncompleteRun" if case["status"] == "incomplete" else "CaseError"
            ET.SubElement(tc, "error", message=case.get("error") or "case failed", type=kind).text = case.get("error")
            continue
        test = case.get("modes", {}).get("test")
        if test is None:
            skipped += 1
            ET.SubElement(tc, "skipped", message="no test-mode run (reproduce only)")
            continue
        bad = {v: test["verdicts"].get(v, 0) for v in ("violation", "collision")}
        if any(bad.values()):
            failures += 1
            codes = ", ".join(f"{code} by {actor} in {n}" for code, actors in sorted(test["violations"].items())
                              for actor, n in sorted(actors.items()))
            message = (f"{bad['violation']} of {test['variations']} variations with a violation by the ADS, "
                       f"{bad['collision']} with a collision")
            ET.SubElement(tc, "failure", message=message, type="ScenarioFailure").text = (
                f"{message}\nviolations: {codes or 'none'}\ncollisions: {test['collisions'] or 'none'}")
    suite.set("failures", str(failures))
    suite.set("errors", str(errors))
    suite.set("skipped", str(skipped))
    suite.set("time", f"{seconds:.3f}")
    ET.indent(suite)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(suite, encoding="unicode") + "\n"
