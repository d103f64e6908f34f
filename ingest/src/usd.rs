//! USD reader (being written).
