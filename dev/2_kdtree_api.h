/* 2_kdtree api: owned by its helper until integration */
