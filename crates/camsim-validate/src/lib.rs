//! camsim validate: the paper's Cornell box validation, end to end, with its report
