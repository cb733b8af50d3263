//! camsim stage 4: demosaic and sRGB preview
