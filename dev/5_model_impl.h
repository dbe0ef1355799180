/* 5_model impl: owned by its helper until integration */
