"""Virtual measurements from the models: train pass-bys (band levels and time signals)."""
