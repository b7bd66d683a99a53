"""crashscene: crash reports to executable ADS test scenarios."""
__version__ = "0.1.0"
