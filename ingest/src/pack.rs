//! Scene → blob (being written).
