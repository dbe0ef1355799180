/* 4_ffd api: owned by its helper until integration */
