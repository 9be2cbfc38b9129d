"""Labelled data sets: a spec names the runs, each rendered into Parquet with its labels.

    DatasetSpec       -- a validated data-set spec and its runs (module ``spec``)
    DatasetSpecError  -- a spec is invalid: the key and why
    Run               -- one run of a data set
    render_dataset    -- render every unfinished run of a spec, locally or on Dask (module ``engine``)
    read_labels       -- the labels table of a data set
    read_run          -- one run's waveforms and metadata
    DatasetError      -- a data set cannot be rendered here
    render_run        -- one run into its files (module ``render``)
"""

from bkabem_core._face import lazy_face

__all__ = ["DatasetSpec", "DatasetSpecError", "Run", "render_dataset", "read_labels", "read_run", "DatasetError", "render_run"]

__getattr__, __dir__ = lazy_face(__name__, {
    "DatasetSpec": "spec",
    "DatasetSpecError": "spec",
    "Run": "spec",
    "render_dataset": "engine",
    "read_labels": "engine",
    "read_run": "engine",
    "DatasetError": "engine",
    "render_run": "render",
})
