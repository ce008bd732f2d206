"""What tests share: oracles, stand-ins, hypothesis strategies, file checks, the
checkout's paths. Imported as `tests.support.<module>`; no test module imports another."""
