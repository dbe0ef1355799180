/* 5_model api: owned by its helper until integration */
