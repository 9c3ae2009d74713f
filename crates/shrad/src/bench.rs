//! `shrad bench`: the paper's Tables 1-3 reproduced in one run (being written).
