//! camsim stage 3: irradiance -> electrons -> volts -> digital values (ISETCam sensor model, presets)
