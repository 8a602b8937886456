"""The ``dpdfit`` command line: a thin layer over the API."""

__all__: list[str] = []
