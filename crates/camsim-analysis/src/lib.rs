//! camsim analysis: ISO 12233 SFR, chart and ROI statistics, QE fit, EMVA 1288
