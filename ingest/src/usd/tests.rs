//! Reader tests on generated .usda stages.
