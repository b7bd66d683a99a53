"""Extract: crash report (narrative + sketch) to an Extended Scenic DSL scenario.

Modules, in data-flow order:

- `report`   read a case folder or a text file into a `Report` (`load_report`)
- `sketch`   offline OCR of the crash sketch into short `SketchFact`s (`sketch_facts`)
- `rules`    deterministic extraction from NHTSA narrative language (`extract_rules`)
- `errors`   the `ExtractError` exception family of this stage

Heavy dependencies (rapidocr, OpenCV, LLM clients) are imported inside the
functions that need them, so importing this package stays cheap.
"""
