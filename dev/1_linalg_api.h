/* 1_linalg api: owned by its helper until integration */
