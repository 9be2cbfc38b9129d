"""Bench helpers that hold bkabem against measured bearing-fault records (the CWRU drive-end records).

The diagnostics here are textbook implementations written for the bench (Randall & Antoni, "Rolling element
bearing diagnostics - a tutorial", MSSP 25 (2011) 485-520; Antoni, "Fast computation of the kurtogram for the
detection of transient faults", MSSP 21 (2007) 108-124). They judge the product, so they never import
``bkabem_core.analysis``; only the twin adapter (:mod:`realdata.twin`) calls the product, to synthesise.

Modules, by data flow:

* :mod:`realdata.records`: a CWRU folder read as records (file name -> speed, load, kind, size, position;
  provenance; the rig's published facts);
* :mod:`realdata.kurtogram`: Antoni's fast kurtogram and the band a textbook analysis picks from it;
* :mod:`realdata.diagnostics`: RMS, kurtosis, crest factor, Welch PSD and band energies, the squared-envelope
  spectrum (SES) with its floor and line levels, the no-training verdict, a tacho-less speed estimate;
* :mod:`realdata.twin`: the twin adapter (a record -> the twin's DE and FE acceleration in g; a record -> the
  run parameters of a ``bkabem dataset`` spec);
* :mod:`realdata.classify`: feature vectors and two transparent classifiers in numpy.

Run from ``bench/`` scripts (``bench/`` is on ``sys.path`` when a script of it runs) or tests that put ``bench/``
on the path.
"""
