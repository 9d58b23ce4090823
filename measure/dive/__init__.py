"""A dive: every photo of a folder measured with its own inputs, on Dask, resumable, with
survey outputs.

:func:`measure_dive` lists the folder (every file is accounted for: measured, or the reason
why not), resolves each photo's inputs (a row of the metadata CSV, :func:`read_metadata`; the
camera's EXIF depth, :func:`exif_info`; the defaults given), measures the photos on a Dask
cluster (a ``distributed.LocalCluster`` by default, or an existing scheduler), writes each
photo's folder whole or not at all (:func:`measure.write_outputs`), skips the photos whose
complete results match the same inputs and options, and writes ``summary.csv``, ``survey.nc``
(CF-1.8) and ``survey.png`` -- also when interrupted, for what is done.

One concept per module:

- :mod:`.metadata`: the metadata CSV and the EXIF depth and time;
- :mod:`.names`: which files are photos, and each photo's output folder name;
- :mod:`.manifest`: run.json, the options that change results (a rerun with others is
  refused);
- :mod:`.plan`: each photo's inputs, the key that says "same inputs", what to do with it;
- :mod:`.worker`: one photo measured and written, in a worker;
- :mod:`.execute`: the jobs run on Dask or in this process, Ctrl-C;
- :mod:`.files`: the output folder locked, the run's files written whole, temporary files
  removed;
- :mod:`.summary`: summary.csv's rows, statuses and exit status;
- :mod:`.survey`: survey.nc (CF-1.8);
- :mod:`.plot`: survey.png;
- :mod:`.run`: :func:`measure_dive`, which ties them together (the joint fit is
  :mod:`measure.joint`).
"""

from __future__ import annotations

from .metadata import (AUXILIARY_COLUMNS, DATETIME_ORIGINAL_TAG, EXIF_DEPTH_TAGS, KD_COLUMN,
                       METADATA_COLUMNS, METADATA_OPTIONAL, WATER_DEPTH_TAG, exif_info,
                       read_metadata)
from .names import LOCK_FILE, MANIFEST, RUN_FILES, dive_files, output_names
from .plot import SURVEY_LOG_SPAN, plot_survey
from .run import DiveResult, DiveWarning, measure_dive
from .summary import STATUSES, SUMMARY_COLUMNS
from .survey import (CDOM_WAVELENGTH_NM, CF_CDOM, CF_CHL, netcdf_engine, path_standard_name,
                     survey_dataset)

__all__ = ["AUXILIARY_COLUMNS", "CDOM_WAVELENGTH_NM", "CF_CDOM", "CF_CHL",
           "DATETIME_ORIGINAL_TAG", "EXIF_DEPTH_TAGS", "KD_COLUMN", "LOCK_FILE", "MANIFEST",
           "METADATA_COLUMNS", "METADATA_OPTIONAL", "RUN_FILES", "STATUSES", "SUMMARY_COLUMNS",
           "SURVEY_LOG_SPAN", "WATER_DEPTH_TAG", "DiveResult", "DiveWarning", "dive_files",
           "exif_info", "measure_dive", "netcdf_engine", "output_names", "path_standard_name",
           "plot_survey", "read_metadata", "survey_dataset"]
