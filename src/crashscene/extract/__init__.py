"""Extract: crash report (narrative + sketch) to an Extended Scenic DSL scenario.

Modules, in data-flow order:

- `report`     read a case folder or a text file into a `Report` (`load_report`)
- `sketch`     offline OCR and line analysis of the crash sketch into short `SketchFact`s (`sketch_facts`)
- `nhtsa_xml`  the case XML's posted limit and coded conditions as facts (`nhtsa_facts`)
- `rules`      deterministic extraction from NHTSA narrative language (`extract_rules`), built from
  `narrative` and the `rules_*` step modules
- `errors`     the `ExtractError` exception family of this stage
- the LLM side (prompt, backends, validation pass, pipeline) builds on the same `Report` and facts

Heavy dependencies (rapidocr, OpenCV, LLM clients) are imported inside the
functions that need them, so importing this package stays cheap.
"""
