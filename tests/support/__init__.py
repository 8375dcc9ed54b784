"""Helpers shared by the tests (importable as ``support``: pytest.ini puts tests/ on the path)."""
