/* 2_kdtree impl: owned by its helper until integration */
