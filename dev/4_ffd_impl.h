/* 4_ffd impl: owned by its helper until integration */
